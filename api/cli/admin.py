"""The database and the REST service: ``rcb db upgrade|prune``, ``rcb keys``, ``rcb serve``.

Each command migrates the database first (``rcb db upgrade`` does nothing else).
``rcb keys create|list|revoke`` manage API keys (a key may be scoped to plans);
``rcb db prune`` deletes old audit entries, idempotency records and replaced band states.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.text import Text

from api.cli.common import (
    DbOption,
    again_db,
    emit,
    engine_of,
    errors,
    plan_of,
    say,
    say_command,
    say_filled,
    shown,
)
from api.cli.tables import new_table, shown_text
from api.cli.who import ByOption, cli_actor
from api.services import request_limits
from api.services.errors import NotFoundError
from api.settings import (
    auth_failure_burst,
    database_field,
    database_url,
    http_limits,
    pool,
    trusted_proxies,
)
from models.bounds import MAX_IDENTITY
from models.errors import InputError

if TYPE_CHECKING:
    from db.engine import Migration

# Each command imports the database layer (SQLAlchemy, Alembic) and the server (uvicorn) when
# it runs: rcb --help and the other commands do not load them (README, "Speed").

#: ``rcb db``.
db_app = typer.Typer(help="The database: migrations, pruning.", no_args_is_help=True)
_out = Console()


def migrate(url: str, field: str = "--db") -> Migration:
    """Migrate the database at ``url`` (named by ``field``) to the newest revision.

    A URL rcb cannot keep data at, or a database it cannot reach, is an InputError with the
    reason and its fix (:mod:`db.urls`). A database already at the newest revision is not
    migrated and its migration lock is not taken: a command (``rcb keys revoke`` in an
    emergency) does not wait for an instance stuck while migrating another copy of rcb's
    schema, or for one holding the lock (a lockout review: every such command hung). A
    database at a revision this rcb does not know (a newer rcb's) is refused as
    :func:`api.cli.common.existing_engine` refuses it, and left as it is.
    """
    from sqlalchemy.exc import ArgumentError, DBAPIError

    from db.engine import HEAD_REVISION, Migration, current_revision, revisions, upgrade
    from db.urls import cannot_use, check, unknown_revision

    check(url, field)
    try:
        found = current_revision(url)
        if found == HEAD_REVISION:
            return Migration(before=HEAD_REVISION, after=HEAD_REVISION)
        if found is not None and found not in revisions():  # a newer rcb's: left as it is
            raise InputError(field, shown(url), unknown_revision(found))
        return upgrade(url)
    except (ArgumentError, DBAPIError) as err:
        raise InputError(field, shown(url), cannot_use(err, url)) from None


@contextmanager
def _using(url: str, field: str) -> Iterator[None]:
    """A database error of the block as one line naming ``field`` and the URL.

    ``--db = 'sqlite:///ro.db': cannot use this database (OperationalError: attempt to write a
    readonly database)``, the password hidden, worded as :func:`migrate` words it
    (:func:`db.urls.cannot_use`); :func:`api.cli.common.errors` said ``--db:`` alone,
    without the URL.
    """
    from sqlalchemy.exc import DBAPIError

    from db.urls import cannot_use

    try:
        yield
    except DBAPIError as err:
        raise InputError(field, shown(url), cannot_use(err, url)) from None


def writable(url: str, field: str = "--db") -> None:
    """Refuse a database that takes no writes (:func:`db.urls.read_only`), naming it.

    ``rcb serve`` checks it before serving: every part report would fail (a read-only SQLite
    file answered ``/ready`` ready, then 500 to each write). A database locked or busy now
    is not refused: ``/ready`` says so while it lasts.
    """
    from sqlalchemy.exc import DBAPIError

    from api.services.readiness import ready
    from db.engine import make_engine
    from db.urls import first_line, read_only

    engine = make_engine(url)
    try:
        ready(engine)
    except DBAPIError as err:
        if not read_only(err):
            return
        reason = (
            f"the database is read-only ({first_line(err)}); rcb serve stores reports: "
            "make it writable"
        )
        raise InputError(field, shown(url), reason) from None
    finally:
        engine.dispose()


@db_app.command("upgrade")
def db_upgrade(db: DbOption = None) -> None:
    """Create or migrate the database to the newest schema; says which revisions it applied."""
    url = database_url(db)
    with errors():
        done = migrate(url, database_field(db))
    if done.before is None:
        say(f"rcb: database {shown(url)} migrated from empty to revision {done.after}")
    elif done.changed():
        say(f"rcb: database {shown(url)} migrated from revision {done.before} to {done.after}")
    else:
        say(f"rcb: database {shown(url)} is up to date (revision {done.after})")


@db_app.command("prune")
def db_prune(
    audit_older_than: Annotated[
        str, typer.Option(help="Delete audit entries older than this (e.g. 365d, 24h, 90m).")
    ] = request_limits.AUDIT_DEFAULT,
    idempotency_older_than: Annotated[
        str, typer.Option(help="Delete idempotency records older than this (at least 24h).")
    ] = request_limits.IDEMPOTENCY_DEFAULT,
    states_older_than: Annotated[
        str,
        typer.Option(
            help="Delete band states older than this that a newer one replaced (each band's "
            "newest is kept, whatever its age)."
        ),
    ] = request_limits.STATES_DEFAULT,
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    by: ByOption = None,
) -> None:
    """Delete old audit entries, idempotency records and replaced band states; prints how many."""
    from api.services import retention
    from db.engine import make_engine

    url = database_url(db)
    with errors():
        actor = cli_actor(by)
        migrate(url, database_field(db))
        with _using(url, database_field(db)):
            pruned = retention.prune(
                engine=make_engine(url),
                audit_older_than=audit_older_than,
                idempotency_older_than=idempotency_older_than,
                states_older_than=states_older_than,
                actor=actor,
            )
    if as_json:
        emit(pruned)
        return
    say_filled(
        f"rcb: deleted {pruned['audit_log']} audit entries older than {audit_older_than}, "
        f"{pruned['idempotency_records']} idempotency records older than "
        f"{idempotency_older_than} and {pruned['band_states']} band states older than "
        f"{states_older_than} that newer ones replaced"
    )


#: ``rcb keys``.
keys_app = typer.Typer(help="API keys of the REST service.", no_args_is_help=True)


@keys_app.command("create")
def keys_create(
    role: Annotated[str, typer.Option(help="mes, engineer or viewer.")],
    label: Annotated[str, typer.Option(help="Who or what the key is for.")] = "",
    plan: Annotated[
        list[str] | None,
        typer.Option(help="A plan the key may see, by id or name (repeat; none: every plan)."),
    ] = None,
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    by: ByOption = None,
) -> None:
    """Create an API key; it is printed once and stored only as a hash."""
    from api.services.keys import create_key
    from db.engine import make_engine

    url = database_url(db)
    with errors():
        actor = cli_actor(by)
        migrate(url, database_field(db))
        engine = make_engine(url)
        plans = None if plan is None else [plan_of(engine, p, "--plan") for p in plan]
        with _using(url, database_field(db)):
            created = create_key(engine=engine, role=role, label=label, plans=plans, actor=actor)
    if as_json:
        emit(created)
        return
    typer.echo(created["key"])
    scope = f"plans {', '.join(map(str, created['plans']))}" if created["plans"] else "every plan"
    say(f"rcb: key {created['id']} ({created['role']}, {scope}) created; it is not shown again")


@keys_app.command("list")
def keys_list(
    limit: Annotated[
        int, typer.Option(help=f"Keys per page (1 to {request_limits.KEYS_PAGE}).")
    ] = 50,
    after: Annotated[int, typer.Option(help="Show keys after this id (the next page).")] = 0,
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List API keys: id, role, label, plans, created, last use (never the key or its hash)."""
    from api.services.keys import list_keys

    with errors():
        page = list_keys(engine=engine_of(db), after=after, limit=limit)
    if as_json:
        emit(page)
        return
    table = new_table("id", "role", "label")
    table.add_column("plans", min_width=len("every plan"))
    for heading in ("created", "last use", "revoked"):
        table.add_column(heading)
    for key in page["keys"]:
        table.add_row(
            str(key["id"]),
            key["role"],
            Text(shown_text(key["label"], MAX_IDENTITY)),  # one stored before the check: cut
            ", ".join(map(str, key["plans"])) if key["plans"] else "every plan",
            _minute(key["created_at"]),
            _minute(key["last_used_at"]) or "never",
            _minute(key["revoked_at"]),
        )
    _out.print(table)
    if page["next_after"] is not None:
        say_command(
            "rcb: more keys:",
            f"rcb keys list --after {page['next_after']} --limit {limit}{again_db(db)}",
        )


def _minute(at: object) -> str:
    """A stored time to the minute (UTC), or empty for none."""
    return at.strftime("%Y-%m-%d %H:%M") if hasattr(at, "strftime") else ""


@keys_app.command("revoke")
def keys_revoke(
    key_id: Annotated[int, typer.Argument(metavar="ID", help="The key's id.")],
    db: DbOption = None,
    by: ByOption = None,
) -> None:
    """Revoke an API key (kept in the audit log, refused from now on)."""
    from api.services.keys import revoke_key

    with errors():
        actor = cli_actor(by)
        engine = engine_of(db)
        try:
            with _using(database_url(db), database_field(db)):
                revoked = revoke_key(engine=engine, key_id=key_id, actor=actor)
        except NotFoundError as err:
            raise InputError("ID", key_id, "no such API key") from err
    if revoked["already"]:
        at = _minute(revoked["revoked_at"])
        say(f"rcb: key {revoked['id']} ({revoked['role']}) was already revoked, at {at} UTC")
        return
    say(f"rcb: key {revoked['id']} ({revoked['role']}) revoked")


def serve(
    db: DbOption = None,
    host: Annotated[str, typer.Option(help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(min=1, max=65535, help="TCP port.")] = 8000,
    workers: Annotated[int, typer.Option(min=1, max=64, help="Worker processes.")] = 1,
    access_log: Annotated[bool, typer.Option(help="Log every request.")] = True,
    forwarded_allow_ips: Annotated[
        str | None,
        typer.Option(
            metavar="IPS",
            help="Proxies whose X-Forwarded-For names the client (the wrong-key limit and "
            "the audit log count it): addresses and networks, '*' or 'none' (default: "
            "$RCB_FORWARDED_ALLOW_IPS, else none: a reverse proxy on this host is 127.0.0.1).",
        ),
    ] = None,
) -> None:
    """Serve the REST API (under /api/v1) with uvicorn; migrates the database first.

    A port in use exits with code 5 and one line; the workers exit when this process dies.
    """
    from api.rest import serving

    url = database_url(db)
    with errors():
        auth_failure_burst()  # a malformed RCB_AUTH_FAILURE_BURST is refused before serving
        pool()  # and a malformed RCB_DB_POOL_SIZE, RCB_DB_MAX_OVERFLOW or RCB_DB_POOL_TIMEOUT
        http_limits()  # and RCB_HTTP_*
        forwarded = trusted_proxies(forwarded_allow_ips)
        migrate(url, database_field(db))
        writable(url, database_field(db))
        try:
            listener = serving.tcp_listener(host, port)
        except serving.PortInUseError as err:
            say(f"rcb: error: {err}")
            raise typer.Exit(serving.EXIT_PORT_IN_USE) from None
        say(f"rcb: serving {shown(url)} on http://{host}:{port}/api/v1 ({workers} worker(s))")
        serving.run(listener, url, workers=workers, access_log=access_log, forwarded=forwarded)
