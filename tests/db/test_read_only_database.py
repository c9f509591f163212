"""A database that takes no writes: /ready and writes are 503 naming it, rcb serve refuses it.

A read-only SQLite file was served: ``/ready`` said ready (its probe wrote nothing, and
``BEGIN IMMEDIATE`` succeeds on a read-only file), then every write was 500 "internal error"
with a traceback in the log; ``rcb keys create`` said ``--db: cannot use this database``
without the URL.
"""

from __future__ import annotations

import shutil
import subprocess

import pytest
from sqlalchemy import create_engine
from sqlalchemy.exc import DBAPIError
from sqlalchemy.pool import NullPool

from api.rest.unavailable import reason, unavailable
from api.services.readiness import ready
from db.urls import read_only

from conftest import engine_url, invoke
from live import free_port


def _read_only_engine(url: str):
    """An engine on ``url``'s database whose connections cannot write."""
    if url.startswith("sqlite"):
        path = url.removeprefix("sqlite:///")
        return create_engine(f"sqlite:///file:{path}?mode=ro&uri=true", poolclass=NullPool)
    options = {"options": "-c default_transaction_read_only=on"}
    return create_engine(url, poolclass=NullPool, connect_args=options)


def test_the_ready_probe_fails_on_a_read_only_database_as_503(engine):
    ro = _read_only_engine(engine_url(engine))
    try:
        with pytest.raises(DBAPIError) as caught:
            ready(ro)
    finally:
        ro.dispose()
    assert read_only(caught.value)
    assert unavailable(caught.value)  # 503, not 500
    assert reason(caught.value) == "the database is not writable (read-only)"
    assert ready(engine) == {"status": "ready"}  # the same database, writable


@pytest.fixture
def immutable(tmp_path, runner):
    """A migrated SQLite file the kernel refuses to write (``chattr +i``: root ignores chmod)."""
    if shutil.which("chattr") is None:
        pytest.skip("no chattr")
    url = f"sqlite:///{tmp_path / 'ro.db'}"
    assert invoke(runner, "db", "upgrade", "--db", url).exit_code == 0
    assert invoke(runner, "keys", "create", "--role", "mes", "--db", url).exit_code == 0
    if subprocess.run(["chattr", "+i", str(tmp_path / "ro.db")], check=False).returncode:
        pytest.skip("chattr +i refused here")
    yield url
    subprocess.run(["chattr", "-i", str(tmp_path / "ro.db")], check=True)


def test_serve_refuses_a_read_only_file(runner, immutable):
    done = invoke(runner, "serve", "--db", immutable, "--port", str(free_port()))
    assert (done.exit_code, done.stderr) == (
        2,
        f"rcb: error: --db = {immutable!r}: the database is read-only (attempt to write a "
        "readonly database); rcb serve stores reports: make it writable\n",
    )


@pytest.mark.parametrize(
    "command", [["keys", "create", "--role", "mes"], ["keys", "revoke", "1"], ["db", "prune"]]
)
def test_a_write_names_the_database(runner, immutable, command):
    done = invoke(runner, *command, "--db", immutable)
    assert (done.exit_code, done.stderr) == (
        2,
        f"rcb: error: --db = {immutable!r}: cannot use this database "
        "(OperationalError: attempt to write a readonly database)\n",
    )


def test_an_upgrade_of_a_read_only_file_is_worded_as_a_write_on_it(tmp_path, runner):
    """``rcb db upgrade`` of a read-only file said SQLAlchemy's wrapper twice over:
    ``(OperationalError: (sqlite3.OperationalError) attempt to write ...)``; it now says what
    ``rcb keys create`` says of the same file (:func:`db.urls.cannot_use`)."""
    if shutil.which("chattr") is None:
        pytest.skip("no chattr")
    path = tmp_path / "empty.db"
    path.write_bytes(b"")  # SQLite's empty database: never migrated
    url = f"sqlite:///{path}"
    if subprocess.run(["chattr", "+i", str(path)], check=False).returncode:
        pytest.skip("chattr +i refused here")
    try:
        done = invoke(runner, "db", "upgrade", "--db", url)
    finally:
        subprocess.run(["chattr", "-i", str(path)], check=True)
    assert (done.exit_code, done.stderr) == (
        2,
        f"rcb: error: --db = {url!r}: cannot use this database "
        "(OperationalError: attempt to write a readonly database)\n",
    )
    assert path.read_bytes() == b""  # nothing written
