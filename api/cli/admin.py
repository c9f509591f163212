"""The database and the REST service: ``rcb db upgrade``, ``rcb keys create|revoke``, ``rcb serve``.

Each command migrates the database first (``rcb db upgrade`` does nothing else).
"""

from __future__ import annotations

from typing import Annotated

import typer
from sqlalchemy.exc import ArgumentError, OperationalError

from api.cli.common import DbOption, emit, errors, say, shown
from api.rest import serving
from api.services.errors import NotFoundError
from api.services.keys import create_key, revoke_key
from api.settings import database_url
from db.engine import make_engine, upgrade
from models.errors import InputError

#: ``rcb db``.
db_app = typer.Typer(help="The database: migrations.", no_args_is_help=True)


def _migrate(url: str) -> None:
    try:
        upgrade(url)
    except (ArgumentError, OperationalError) as err:
        raise InputError(
            "--db",
            url,
            f"cannot use this database ({err.__class__.__name__}: {str(err).splitlines()[0]})",
        ) from None


@db_app.command("upgrade")
def db_upgrade(db: DbOption = None) -> None:
    """Create or migrate the database to the newest schema."""
    url = database_url(db)
    with errors():
        _migrate(url)
    say(f"rcb: database {shown(url)} is up to date")


#: ``rcb keys``.
keys_app = typer.Typer(help="API keys of the REST service.", no_args_is_help=True)


@keys_app.command("create")
def keys_create(
    role: Annotated[str, typer.Option(help="mes, engineer or viewer.")],
    label: Annotated[str, typer.Option(help="Who or what the key is for.")] = "",
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Create an API key; it is printed once and stored only as a hash."""
    url = database_url(db)
    with errors():
        _migrate(url)
        created = create_key(engine=make_engine(url), role=role, label=label)
    if as_json:
        emit(created)
        return
    typer.echo(created["key"])
    say(f"rcb: key {created['id']} ({created['role']}) created; it is not shown again")


@keys_app.command("revoke")
def keys_revoke(
    key_id: Annotated[int, typer.Argument(metavar="ID", help="The key's id.")],
    db: DbOption = None,
) -> None:
    """Revoke an API key (kept in the audit log, refused from now on)."""
    url = database_url(db)
    with errors():
        _migrate(url)
        try:
            revoked = revoke_key(engine=make_engine(url), key_id=key_id)
        except NotFoundError as err:
            raise InputError("ID", key_id, "no such API key") from err
    say(f"rcb: key {revoked['id']} ({revoked['role']}) revoked")


def serve(
    db: DbOption = None,
    host: Annotated[str, typer.Option(help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(min=1, max=65535, help="TCP port.")] = 8000,
    workers: Annotated[int, typer.Option(min=1, max=64, help="Worker processes.")] = 1,
    access_log: Annotated[bool, typer.Option(help="Log every request.")] = True,
) -> None:
    """Serve the REST API (under /api/v1) with uvicorn; migrates the database first.

    A port in use exits with code 5 and one line; the workers exit when this process dies.
    """
    url = database_url(db)
    with errors():
        _migrate(url)
        try:
            listener = serving.tcp_listener(host, port)
        except serving.PortInUseError as err:
            say(f"rcb: error: {err}")
            raise typer.Exit(serving.EXIT_PORT_IN_USE) from None
        say(f"rcb: serving {shown(url)} on http://{host}:{port}/api/v1 ({workers} worker(s))")
        serving.run(listener, url, workers=workers, access_log=access_log)
