"""``rcb db prune``'s band states at scale: what a history holds, what a prune frees, and whether
a batch costs more as the history grows.

For each size, ``PLANS`` demonstration plans of ``--parts`` parts each (``rcb demo``, the
``learn`` strategy, into one SQLite file; PostgreSQL too with ``--postgres URL``, a server
database the script empties first), every part then made 31 days old. It prints the database's
size, its band states, the prune's batches (rows and seconds: the first, the median and the
last, which a cost that grows with what is left or already gone would set apart) and the
size after ``VACUUM`` (SQLite). Run::

    .venv/bin/python benchmarks/state_prune.py --plans 1 4 [--parts 1000] [--postgres URL]
"""

from __future__ import annotations

import argparse
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import closing
from datetime import timedelta
from pathlib import Path

from sqlalchemy import func, select, text
from sqlalchemy.orm import Session

from api.services import retention
from db import tables as t
from db.engine import make_engine

RCB = str(Path(sys.executable).with_name("rcb"))


def grow(url: str, plans: int, parts: int) -> None:
    """``plans`` demonstration runs of ``parts`` parts each into ``url``, then all 31 days old."""
    for seed in range(plans):
        subprocess.run(
            [RCB, "demo", "--parts", str(parts), "--seed", str(seed + 1), "--db", url],
            check=True,
            capture_output=True,
        )
    engine = make_engine(url)
    with Session(engine) as session, session.begin():
        session.execute(
            t.Part.__table__.update().values(received_at=t.Part.received_at - timedelta(days=31))
        )
    engine.dispose()


def prune(url: str) -> list[tuple[int, float]]:
    """The prune's batches, as ``rcb db prune`` runs them: (rows deleted, seconds) each."""
    engine = make_engine(url)
    batches = retention.state_batches(engine, t.utcnow() - timedelta(days=30))
    timed = []
    while True:
        started = time.perf_counter()
        done = next(batches, None)
        if done is None:
            break
        timed.append((done, time.perf_counter() - started))
    engine.dispose()
    return timed


def states(url: str) -> int:
    engine = make_engine(url)
    with Session(engine) as session:
        count = int(session.scalar(select(func.count()).select_from(t.BandState)) or 0)
    engine.dispose()
    return count


def report(label: str, url: str, path: Path | None) -> None:
    """Prune ``url`` and print what it held, the batches and what it holds after."""
    size = f", {path.stat().st_size / 1e6:.1f} MB" if path else ""
    print(f"{label}: {states(url)} band states{size}")
    batches = prune(url)
    seconds = [s for _, s in batches]
    rows = sum(n for n, _ in batches)
    print(
        f"  pruned {rows} rows in {len(batches)} batches, {sum(seconds):.2f} s; a batch: first "
        f"{seconds[0] * 1e3:.0f} ms, median {statistics.median(seconds) * 1e3:.0f} ms, last "
        f"{seconds[-1] * 1e3:.0f} ms ({batches[-1][0]} rows)"
    )
    if path:
        with closing(sqlite3.connect(path, isolation_level=None)) as connection:
            connection.execute("VACUUM")
        print(f"  left {states(url)} band states, {path.stat().st_size / 1e6:.1f} MB after VACUUM")
    else:
        print(f"  left {states(url)} band states")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plans", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--parts", type=int, default=1000)
    parser.add_argument("--postgres", help="a PostgreSQL URL whose database is emptied first")
    args = parser.parse_args()
    for plans in args.plans:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "rcb.db"
            url = f"sqlite:///{path}"
            grow(url, plans, args.parts)
            report(f"SQLite, {plans} x {args.parts} parts", url, path)
        if args.postgres:
            engine = make_engine(args.postgres)
            with engine.begin() as connection:
                connection.execute(text("DROP SCHEMA public CASCADE; CREATE SCHEMA public"))
            engine.dispose()
            grow(args.postgres, plans, args.parts)
            report(f"PostgreSQL, {plans} x {args.parts} parts", args.postgres, None)


if __name__ == "__main__":
    main()
