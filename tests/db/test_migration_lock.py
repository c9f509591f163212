"""Instances starting at once on one database migrate one after another (issue 29, item 3).

Before: 2 ``rcb serve`` starting together on a fresh PostgreSQL database, one exited with a
traceback in 3/3 trials (UniqueViolation on ``alembic_version``); on a database at 0005, 2/3
(DuplicateColumn ``api_keys.plans``). Now the upgrade holds a lock (db/migrate.py).
"""

from __future__ import annotations

import subprocess
import threading
import time
from pathlib import Path

import httpx
import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import text

from db.engine import MIGRATIONS, make_engine, upgrade
from db.migrate import migration_lock
from db.tables import Base

from live import LOOPBACK_TLS, RCB, free_port, stop_group

INSTANCES = 3
#: Seconds for all instances to answer (each imports the solver stack, on 2 shared cores).
START_S = 120.0


def _head() -> str:
    head = ScriptDirectory(str(MIGRATIONS)).get_current_head()
    assert head is not None
    return head


def _at_head(url: str) -> None:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            versions = connection.execute(text("SELECT version_num FROM alembic_version")).all()
            context = MigrationContext.configure(connection, opts={"compare_type": True})
            assert compare_metadata(context, Base.metadata) == []
    finally:
        engine.dispose()
    assert [v[0] for v in versions] == [_head()]


def _start_together(url: str, logs: Path) -> None:
    """Start INSTANCES ``rcb serve`` at once on ``url``; all of them must answer."""
    ports = [free_port() for _ in range(INSTANCES)]
    processes = []
    for i, port in enumerate(ports):
        command = [str(RCB), "serve", "--db", url, "--port", str(port), "--no-access-log"]
        with (logs / f"serve{i}.log").open("wb") as log:
            processes.append(
                subprocess.Popen(
                    command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
                )
            )
    try:
        waiting = dict(enumerate(ports))
        deadline = time.monotonic() + START_S
        while waiting and time.monotonic() < deadline:
            for i, port in list(waiting.items()):
                log = (logs / f"serve{i}.log").read_text()
                assert processes[i].poll() is None, f"instance {i} exited: {log[-3000:]}"
                try:
                    r = httpx.get(
                        f"http://127.0.0.1:{port}/api/v1/health", timeout=1.0, verify=LOOPBACK_TLS
                    )
                    if r.status_code == 200:
                        del waiting[i]
                except httpx.HTTPError:
                    pass
            time.sleep(0.2)
        assert not waiting, f"instances {sorted(waiting)} did not answer in {START_S} s"
    finally:
        for process in processes:
            if process.poll() is None:
                stop_group(process)
    for i in range(INSTANCES):
        assert "Traceback" not in (logs / f"serve{i}.log").read_text()


@pytest.mark.parametrize("start", ["fresh", "0005"])
def test_instances_started_together_all_serve_at_head(backend_url, tmp_path, start):
    if start != "fresh":
        upgrade(backend_url, start)  # a rolling upgrade: the database an older release left
    _start_together(backend_url, tmp_path)
    _at_head(backend_url)


def test_an_upgrade_waits_for_the_lock(backend_url):
    """While the lock is held nothing is migrated; released, the upgrade runs to head."""
    done = threading.Event()
    failed: list[BaseException] = []

    def migrate() -> None:
        try:
            upgrade(backend_url)
        except BaseException as err:  # reported below, in the test's thread
            failed.append(err)
        done.set()

    with migration_lock(backend_url):
        waiter = threading.Thread(target=migrate, daemon=True)
        waiter.start()
        assert not done.wait(2.0)  # blocked on the lock (it would finish in well under 2 s)
        engine = make_engine(backend_url)
        with engine.connect() as connection:  # nothing created yet
            tables = connection.dialect.get_table_names(connection)
        engine.dispose()
        assert "alembic_version" not in tables
    assert done.wait(120.0) and not failed, failed
    _at_head(backend_url)


def test_commands_on_a_database_at_head_do_not_wait_for_the_lock(backend_url):
    """A lockout review: with the migration lock held (an instance stuck migrating, or one that
    hangs holding it), every ``rcb keys`` command hung, ``keys revoke`` in an emergency too.
    A database already at head is used as it is; the lock is taken only to migrate."""
    upgrade(backend_url)
    said = []
    with migration_lock(backend_url):
        for args in (["keys", "create", "--role", "mes"], ["keys", "revoke", "1"], ["db", "prune"]):
            done = subprocess.run(
                [str(RCB), *args, "--db", backend_url],
                capture_output=True,
                text=True,
                timeout=60,
                check=False,
            )
            assert done.returncode == 0, (args, done.stderr)
            said.append(done.stderr + done.stdout)
    assert "rcb: key 1 (mes) revoked" in said[1]
