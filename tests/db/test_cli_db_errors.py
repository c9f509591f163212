"""A new user's database mistakes: one line each, with the fix, exit 2, never a traceback.

Issue 30: ``rcb plans`` on a fresh PostgreSQL database printed a 96-line traceback, ``--db
mysql://...`` a ModuleNotFoundError, ``--db sqlite:///:memory:`` a TypeError; a server that did
not answer was reported as "is it migrated?"; ``rcb db upgrade`` said "is up to date" after
migrating an empty database. Each is run here as the real ``rcb`` in a subprocess, with the URL
given by ``--db`` and by ``RCB_DATABASE_URL``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from sqlalchemy.engine import make_url

from db.engine import revisions, upgrade
from db.urls import SUPPORTED

from conftest import ROOT

HEAD = revisions()[-1]
#: A PostgreSQL URL at a port nothing listens on.
NOBODY = "postgresql+psycopg://postgres@127.0.0.1:1/x"
SUPPORTED_TEXT = ", ".join(f"{name} ({example})" for name, example in SUPPORTED.items())


def rcb(*args: str, env_url: str | None = None, cwd: Path = ROOT) -> tuple[int, str]:
    """Exit code and stderr of the real ``rcb``; its stdout must be empty, no traceback."""
    script = Path(sys.executable).parent / "rcb"
    if not script.is_file():
        pytest.skip("the rcb console script is not installed")
    env = {k: v for k, v in os.environ.items() if k != "RCB_DATABASE_URL"}
    if env_url is not None:
        env["RCB_DATABASE_URL"] = env_url
    done = subprocess.run(
        [str(script), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=120
    )
    assert "Traceback" not in done.stderr, done.stderr
    return done.returncode, done.stderr


def one_line(*args: str, env_url: str | None = None, cwd: Path = ROOT) -> str:
    """The one line ``rcb`` prints on stderr, exiting 2."""
    code, stderr = rcb(*args, env_url=env_url, cwd=cwd)
    assert code == 2, stderr
    assert stderr.count("\n") == 1, stderr
    return stderr.rstrip("\n")


@pytest.mark.parametrize("command", [["plans"], ["history", "1"]])
def test_sqlite_file_not_migrated(tmp_path, command):
    (tmp_path / "fresh.db").touch()
    url = f"sqlite:///{tmp_path / 'fresh.db'}"
    assert one_line(*command, "--db", url) == (
        f"rcb: error: --db = {url!r}: the database is not migrated; run rcb db upgrade --db {url}"
    )
    assert one_line(*command, env_url=url) == (
        f"rcb: error: RCB_DATABASE_URL = {url!r}: the database is not migrated; run rcb db upgrade"
    )


def test_sqlite_behind_head(tmp_path):
    url = f"sqlite:///{tmp_path / 'old.db'}"
    older = revisions()[-2]
    upgrade(url, older)
    assert one_line("plans", "--db", url) == (
        f"rcb: error: --db = {url!r}: the database is at revision {older}, not {HEAD}; "
        f"run rcb db upgrade --db {url}"
    )


def test_missing_sqlite_file(tmp_path):
    url = f"sqlite:///{tmp_path / 'none.db'}"
    assert one_line("history", "1", "--db", url) == (
        f"rcb: error: --db = {url!r}: no such database file; create it: rcb db upgrade --db {url}"
    )
    assert not (tmp_path / "none.db").exists()


@pytest.mark.parametrize("command", [["plans"], ["db", "upgrade"]])
def test_unsupported_driver(command):
    url = "mysql://rcb@db.example/rcb"
    reason = f"unsupported database driver 'mysql'; use {SUPPORTED_TEXT}"
    assert one_line(*command, "--db", url) == f"rcb: error: --db = {url!r}: {reason}"
    assert one_line(*command, env_url=url) == f"rcb: error: RCB_DATABASE_URL = {url!r}: {reason}"


def test_unsupported_driver_hides_password():
    line = one_line("plans", "--db", "mysql://rcb:secret@db.example/rcb")
    assert "secret" not in line and "'mysql://rcb:***@db.example/rcb'" in line


@pytest.mark.parametrize("command", [["plans"], ["db", "upgrade"], ["keys", "list"]])
@pytest.mark.parametrize("url", ["sqlite:///:memory:", "sqlite://"])
def test_in_memory_refused(command, url):
    assert one_line(*command, "--db", url) == (
        f"rcb: error: --db = {url!r}: an in-memory database keeps nothing after rcb exits; "
        "give a file, e.g. sqlite:///./rcb.db"
    )


@pytest.mark.parametrize("command", [["plans"], ["history", "1"], ["db", "upgrade"]])
def test_server_not_answering(command):
    assert one_line(*command, "--db", NOBODY) == (
        f"rcb: error: --db = {NOBODY!r}: the server does not answer at 127.0.0.1:1 "
        "(is PostgreSQL running there?)"
    )
    assert one_line(*command, env_url=NOBODY).startswith(
        f"rcb: error: RCB_DATABASE_URL = {NOBODY!r}"
    )


@pytest.mark.parametrize("command", [["plans"], ["db", "upgrade"]])
def test_path_instead_of_url(tmp_path, command):
    absolute = str(tmp_path / "x.db")
    assert one_line(*command, "--db", absolute) == (
        f"rcb: error: --db = {absolute!r}: a file path, not a database URL; "
        f"write it as sqlite:///{absolute}"
    )
    assert f"sqlite:////{absolute.lstrip('/')}" == f"sqlite:///{absolute}"  # four slashes
    relative = one_line(*command, "--db", "x.db", cwd=tmp_path)
    assert relative.endswith(f"write it as sqlite:///{tmp_path.resolve() / 'x.db'}")
    assert not (tmp_path / "x.db").exists()


def test_db_upgrade_says_what_it_did(tmp_path):
    url = f"sqlite:///{tmp_path / 'new.db'}"
    assert rcb("db", "upgrade", "--db", url) == (
        0,
        f"rcb: database {url} migrated from empty to revision {HEAD}\n",
    )
    assert rcb("db", "upgrade", "--db", url) == (
        0,
        f"rcb: database {url} is up to date (revision {HEAD})\n",
    )
    older = f"sqlite:///{tmp_path / 'older.db'}"
    upgrade(older, revisions()[-2])
    assert rcb("db", "upgrade", "--db", older) == (
        0,
        f"rcb: database {older} migrated from revision {revisions()[-2]} to {HEAD}\n",
    )


@pytest.mark.parametrize("command", [["plans"], ["history", "1"]])
def test_postgres_not_migrated(empty_postgres, command):
    url = empty_postgres
    assert one_line(*command, "--db", url) == (
        f"rcb: error: --db = {url!r}: the database is not migrated; run rcb db upgrade --db {url}"
    )


def test_postgres_upgrade_then_plans(empty_postgres):
    url = empty_postgres
    assert rcb("db", "upgrade", "--db", url) == (
        0,
        f"rcb: database {url} migrated from empty to revision {HEAD}\n",
    )
    code, stderr = rcb("plans", "--db", url)
    assert (code, stderr) == (0, "")


def test_postgres_no_such_database(empty_postgres):
    parsed = make_url(empty_postgres)
    url = parsed.set(database="rcb_no_such_database").render_as_string(hide_password=False)
    where = f"{parsed.host}:{parsed.port or 5432}"
    assert one_line("plans", "--db", url) == (
        f"rcb: error: --db = {url!r}: the server at {where} has no database "
        f"'rcb_no_such_database'; create it (createdb -h {parsed.host} -p {parsed.port or 5432} "
        "rcb_no_such_database), then rcb db upgrade"
    )
