"""The long plan histories of the scale tests, reported once per run and copied to each test.

The scale tests of the report, the history page and the state read (test_report_scale.py,
test_history_scale.py, test_state_scale.py) each reported the same virtual-lathe parts of
``test_service.BODY`` into a fresh SQLite database: 1,500 bayes reports in all, 12-50 s a
test. Here the reports of one strategy are made once per run, through the same
``report_part`` calls, by the first test (of any xdist worker) that asks; the others wait on
a lock. The database is copied whole (SQLite's backup API) after each part count some test
reads, and each test gets its own copy of the count it asks for: what it reads is what it
would have written itself, since the reports are the same and made in the same order.

On PostgreSQL a test still reports the parts into its own database (:class:`Reported`).
"""

from __future__ import annotations

import fcntl
import os
import sqlite3
from pathlib import Path
from typing import Any

from sqlalchemy import Engine
from test_service import BODY, _reports

from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine, upgrade
from supervisor.rcb.state import RcbSettings

#: The plan's id in each database (the first and only plan).
PLAN_ID = 1
#: Per strategy (None: the default), the part counts some test reads.
SNAPSHOTS: dict[str | None, tuple[int, ...]] = {
    "bayes": (19, 20, 300, 399, 400),
    "ivester": (20, 300),
    None: (400,),
}


def settings_of(strategy: str | None) -> RcbSettings | None:
    return None if strategy is None else RcbSettings(strategy)


def _run_folder(tmp_path_factory: Any) -> Path:
    """A folder every xdist worker of this run shares (the run's own folder without xdist)."""
    base: Path = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def _copy(source: Path, target: Path) -> None:
    """A consistent copy of a SQLite database (WAL included), whatever is connected to it."""
    with sqlite3.connect(source) as src, sqlite3.connect(target) as dst:
        src.backup(dst)
    src.close()
    dst.close()


def _build(folder: Path, strategy: str | None) -> None:
    """Report the strategy's parts into one database, copied at each count of SNAPSHOTS."""
    counts = SNAPSHOTS[strategy]
    work = folder / "work.db"
    url = f"sqlite:///{work}"
    upgrade(url)
    engine = make_engine(url)
    settings = settings_of(strategy)
    bodies, _ = _reports(max(counts), settings=settings)
    assert create_plan(engine=engine, body=BODY, settings=settings).body["id"] == PLAN_ID
    done = 0
    for count in counts:
        for body in bodies[done:count]:
            assert report_part(engine=engine, plan_id=PLAN_ID, body=body).status == 201
        done = count
        _copy(work, folder / f"{count}.db")
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


class Copied:
    """The plan :data:`PLAN_ID` of ``strategy`` after n reports, each a copy of the shared
    SQLite database (in ``tmp``), its engine disposed by :meth:`close`."""

    def __init__(self, tmp_path_factory: Any, tmp: Path, strategy: str | None) -> None:
        self.factory, self.tmp, self.strategy = tmp_path_factory, tmp, strategy
        self.engines: list[Engine] = []

    def at(self, parts: int) -> Engine:
        target = self.tmp / f"copy-{parts}-{len(self.engines)}.db"
        _copy(_snapshot(self.factory, self.strategy, parts), target)
        engine = make_engine(f"sqlite:///{target}")
        self.engines.append(engine)
        return engine

    def close(self) -> None:
        for engine in self.engines:
            engine.dispose()


class Reported:
    """The same plan reported into one database as the counts are asked for (increasing)."""

    def __init__(self, engine: Engine, strategy: str | None) -> None:
        self.engine, self.strategy, self.done = engine, strategy, 0
        self.bodies: list[dict[str, Any]] = []

    def at(self, parts: int) -> Engine:
        settings = settings_of(self.strategy)
        if not self.bodies:
            self.bodies, _ = _reports(max(SNAPSHOTS[self.strategy]), settings=settings)
            plan = create_plan(engine=self.engine, body=BODY, settings=settings).body
            assert plan["id"] == PLAN_ID
        assert parts >= self.done, (self.done, parts)
        for body in self.bodies[self.done : parts]:
            assert report_part(engine=self.engine, plan_id=PLAN_ID, body=body).status == 201
        self.done = parts
        return self.engine

    def close(self) -> None:
        pass
