"""The long plan histories of the scale tests, reported once per run and copied to each test.

The scale tests of the report, the history page, the state read and the model versions' page
(test_report_scale.py, test_history_scale.py, test_state_scale.py, test_list_paging.py) each
reported the same virtual-lathe parts of ``test_service.BODY`` into a fresh database: 1,600
bayes reports in all on SQLite, 860 on PostgreSQL, 10-50 s a test. Here the reports of one
strategy are made once per run, through the same ``report_part`` calls, by the first test
(of any xdist worker) that asks; the others wait on a lock. The SQLite database is copied
whole (SQLite's backup API) after each part count some test reads, and each test gets its
own copy of the count it asks for: what it reads is what it would have written itself, since
the reports are the same and made in the same order.

On PostgreSQL the same: the bayes reports are made once into one database, which is copied
(``CREATE DATABASE ... TEMPLATE``) at each count; each test gets its own database made from
the copy (:class:`PostgresCopied`); the copies are dropped when the run ends
(:func:`drop_postgres_snapshots`, from conftest's ``pytest_sessionfinish``).
"""

from __future__ import annotations

import fcntl
import os
import uuid
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, text
from sqlalchemy.engine import make_url
from test_service import BODY, _reports

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine
from supervisor.rcb.state import RcbSettings

from migrated import admin_engine, copy_sqlite, migrated

#: The plan's id in each database (the first and only plan).
PLAN_ID = 1
#: Per strategy (None: the default), the part counts some test reads.
SNAPSHOTS: dict[str | None, tuple[int, ...]] = {
    "bayes": (4, 19, 20, 59, 300, 399, 400),
    "ivester": (20, 300),
    None: (400,),
}


#: The bayes counts the PostgreSQL tests read (test_history_scale, test_report_scale,
#: test_list_paging).
POSTGRES_SNAPSHOTS = (4, 19, 20, 59, 399, 400)
#: The folder, in the run's shared folder, whose file ``databases`` names the PostgreSQL
#: databases the run made (one a line).
POSTGRES_FOLDER = "history-bayes-postgres"


def settings_of(strategy: str | None) -> RcbSettings | None:
    return None if strategy is None else RcbSettings(strategy)


def _run_folder(tmp_path_factory: Any) -> Path:
    """A folder every xdist worker of this run shares (the run's own folder without xdist)."""
    base: Path = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def _build(folder: Path, strategy: str | None) -> None:
    """Report the strategy's parts into one database, copied at each count of SNAPSHOTS."""
    counts = SNAPSHOTS[strategy]
    work = folder / "work.db"
    url = f"sqlite:///{work}"
    migrated(url)
    engine = make_engine(url)
    settings = settings_of(strategy)
    bodies, _ = _reports(max(counts), settings=settings)
    assert create_plan(engine=engine, body=BODY, settings=settings).body["id"] == PLAN_ID
    done = 0
    for count in counts:
        for body in bodies[done:count]:
            assert (
                report_part(engine=engine, plan_id=PLAN_ID, report=parse_report(body)).status == 201
            )
        done = count
        copy_sqlite(work, folder / f"{count}.db")
    engine.dispose()
    work.unlink()


def _snapshot(tmp_path_factory: Any, strategy: str | None, parts: int) -> Path:
    """The shared database of ``strategy`` after ``parts`` reports (built on first use)."""
    assert parts in SNAPSHOTS[strategy], (strategy, parts)
    folder = _run_folder(tmp_path_factory) / f"history-{strategy or 'default'}"
    folder.mkdir(exist_ok=True)
    with (folder / "lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not (folder / "built").exists():
            _build(folder, strategy)
            (folder / "built").touch()
    return folder / f"{parts}.db"


def _database(server: str, name: str) -> str:
    return make_url(server).set(database=name).render_as_string(hide_password=False)


def _build_postgres(folder: Path, server: str) -> None:
    """The bayes reports into one PostgreSQL database, copied at each POSTGRES_SNAPSHOTS."""
    stem = f"rcb_test_hist_{uuid.uuid4().hex[:8]}"
    names = folder / "databases"
    work = f"{stem}_work"
    admin = admin_engine(server)
    try:
        with admin.connect() as connection:
            names.write_text(f"{work}\n")
            connection.execute(text(f'CREATE DATABASE "{work}"'))
        url = _database(server, work)
        migrated(url)
        settings = settings_of("bayes")
        bodies, _ = _reports(max(POSTGRES_SNAPSHOTS), settings=settings)
        done = 0
        for count in POSTGRES_SNAPSHOTS:
            engine = make_engine(url)
            if done == 0:
                plan = create_plan(engine=engine, body=BODY, settings=settings).body
                assert plan["id"] == PLAN_ID
            for body in bodies[done:count]:
                assert (
                    report_part(engine=engine, plan_id=PLAN_ID, report=parse_report(body)).status
                    == 201
                )
            done = count
            engine.dispose()  # and its read pool: a template has no one connected
            with admin.connect() as connection, names.open("a") as listed:
                listed.write(f"{stem}_{count}\n")
                connection.execute(text(f'CREATE DATABASE "{stem}_{count}" TEMPLATE "{work}"'))
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE "{work}" WITH (FORCE)'))
    finally:
        admin.dispose()


def _postgres_snapshot(tmp_path_factory: Any, server: str, parts: int) -> str:
    """The name of the shared PostgreSQL database after ``parts`` bayes reports."""
    assert parts in POSTGRES_SNAPSHOTS, parts
    folder = _run_folder(tmp_path_factory) / POSTGRES_FOLDER
    folder.mkdir(exist_ok=True)
    with (folder / "lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / "built").exists():
            _build_postgres(folder, server)
            (folder / "built").touch()
    work = (folder / "databases").read_text().split()[0]
    return f"{work.removesuffix('_work')}_{parts}"


def drop_postgres_snapshots(base: Path, server: str) -> None:
    """Drop the copies the run made (``base``: the run's shared folder), if it made any."""
    names = base / POSTGRES_FOLDER / "databases"
    if not names.exists():
        return
    admin = admin_engine(server)
    try:
        with admin.connect() as connection:
            for name in names.read_text().split():
                connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()
    names.unlink()


class PostgresCopied:
    """The bayes plan after n reports, each a new database made from the shared copy."""

    def __init__(self, tmp_path_factory: Any, server: str) -> None:
        self.factory, self.server = tmp_path_factory, server
        self.made: list[tuple[str, Engine]] = []

    def at(self, parts: int) -> Engine:
        template = _postgres_snapshot(self.factory, self.server, parts)
        name = f"rcb_test_{uuid.uuid4().hex[:12]}"
        admin = admin_engine(self.server)
        try:
            with admin.connect() as connection:
                connection.execute(text(f'CREATE DATABASE "{name}" TEMPLATE "{template}"'))
        finally:
            admin.dispose()
        engine = make_engine(_database(self.server, name))
        self.made.append((name, engine))
        return engine

    def close(self) -> None:
        admin = admin_engine(self.server)
        try:
            for name, engine in self.made:
                engine.dispose()
                with admin.connect() as connection:
                    connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        finally:
            admin.dispose()


class Copied:
    """The plan :data:`PLAN_ID` of ``strategy`` after n reports, each a copy of the shared
    SQLite database (in ``tmp``), its engine disposed by :meth:`close`."""

    def __init__(self, tmp_path_factory: Any, tmp: Path, strategy: str | None) -> None:
        self.factory, self.tmp, self.strategy = tmp_path_factory, tmp, strategy
        self.engines: list[Engine] = []

    def at(self, parts: int) -> Engine:
        target = self.tmp / f"copy-{parts}-{len(self.engines)}.db"
        copy_sqlite(_snapshot(self.factory, self.strategy, parts), target)
        engine = make_engine(f"sqlite:///{target}")
        self.engines.append(engine)
        return engine

    def close(self) -> None:
        for engine in self.engines:
            engine.dispose()
