"""A database a newer rcb migrated: ``rcb db upgrade`` and ``rcb serve`` refuse it, untouched.

Before, both printed Alembic's traceback (``CommandError: Can't locate revision identified by
'0099'``) and exited 1, where ``rcb keys list`` already said the line below, exit 2.
"""

from __future__ import annotations

import pytest
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url
from sqlalchemy.pool import NullPool

from db.engine import upgrade

from conftest import invoke
from live import free_port

NEWER = "0099"


def _set_revision(url: str, revision: str | None = None) -> str:
    """Set (or, without ``revision``, read) the database's ``alembic_version``."""
    engine = create_engine(url, poolclass=NullPool)
    try:
        with engine.begin() as connection:
            if revision is not None:
                connection.execute(
                    text("UPDATE alembic_version SET version_num = :r"), {"r": revision}
                )
            return str(connection.execute(text("SELECT version_num FROM alembic_version")).scalar())
    finally:
        engine.dispose()


@pytest.mark.parametrize(
    "command",
    [
        ["db", "upgrade"],
        ["serve", "--port", str(free_port())],
        ["db", "prune"],
        ["keys", "create", "--role", "mes"],
    ],
    ids=["upgrade", "serve", "prune", "keys-create"],
)
def test_a_newer_revision_is_one_line_and_left_as_it_is(runner, backend_url, command):
    upgrade(backend_url)
    _set_revision(backend_url, NEWER)
    done = invoke(runner, *command, "--db", backend_url)
    shown = make_url(backend_url).render_as_string(hide_password=True)
    assert done.exit_code == 2, done.output
    assert done.stderr == (
        f"rcb: error: --db = {shown!r}: the database is at revision {NEWER!r}, "
        "unknown to this rcb (a newer one?)\n"
    )
    assert _set_revision(backend_url) == NEWER
