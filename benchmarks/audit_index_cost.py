"""What ``rcb audit``'s three indexes cost a part report (alembic 0024 and 0026).

Every part report appends an audit entry, so ``ix_audit_log_action_at``,
``ix_audit_log_actor_at`` and ``ix_audit_log_plan_id_at`` are written once per report. Two
databases of one backend, each with a year's log behind it (``--log`` entries) and the
demonstration plan, one with the indexes and one without; the same ``--reports`` part reports
(a virtual lathe's) go through the real use case (``api.services.parts.report_part``) into
both, alternating which goes first, and the script prints the median latency of each and the
ratio. Run (PostgreSQL: the URL of a server
where it may create and drop ``rcb_audit_cost_*`` databases)::

    .venv/bin/python benchmarks/audit_index_cost.py [--reports 100] [--log 200000]
        [--postgres postgresql+psycopg://postgres@127.0.0.1:5432/postgres]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from history_scale import BODY, Lathe  # type: ignore[import-not-found]  # benchmarks/
from sqlalchemy import Engine, text

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine, upgrade
from supervisor.rcb.state import RcbSettings

#: The log written before the reports: ``n`` rows of the kind a year of reports leaves.
FILL = (
    "INSERT INTO audit_log (at, actor, action, target, result, plan_id) "
    "SELECT CURRENT_TIMESTAMP, 'key:1', 'report part', 'plan 9 part x', '201', 9 FROM "
    "(WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n WHERE i < :n) "
    "SELECT i FROM n) AS s"
)


def database(url: str, indexed: bool, log: int) -> tuple[Engine, int]:
    """A migrated database at ``url`` with ``log`` audit entries and the plan: (engine, plan)."""
    upgrade(url)
    engine = make_engine(url)
    with engine.begin() as connection:
        if not indexed:
            connection.execute(text("DROP INDEX ix_audit_log_action_at"))
            connection.execute(text("DROP INDEX ix_audit_log_actor_at"))
            connection.execute(text("DROP INDEX ix_audit_log_plan_id_at"))
        connection.execute(text(FILL), {"n": log})
    return engine, int(create_plan(engine=engine, body=BODY).body["id"])


def _postgres(admin_url: str, name: str) -> str:
    admin = make_engine(admin_url).execution_options(isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f"DROP DATABASE IF EXISTS {name}"))
        connection.execute(text(f"CREATE DATABASE {name}"))
    admin.dispose()
    return admin_url.rsplit("/", 1)[0] + "/" + name


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reports", type=int, default=100, help="part reports into each database")
    parser.add_argument("--log", type=int, default=200_000, help="audit entries already stored")
    parser.add_argument("--postgres", help="an admin URL: run on PostgreSQL, not SQLite")
    args = parser.parse_args(argv)
    if not (1 <= args.reports <= 10_000 and 0 <= args.log <= 10_000_000):
        parser.error("--reports must be 1..10000 and --log 0..10000000")
    lathe = Lathe(RcbSettings())  # the demonstration plan's reports, as history_scale's
    bodies = [lathe.next() for _ in range(args.reports)]
    with tempfile.TemporaryDirectory() as folder:
        engines = {}
        for name, indexed in (("with", True), ("without", False)):
            if args.postgres:
                url = _postgres(args.postgres, f"rcb_audit_cost_{name}")
            else:
                url = f"sqlite:///{Path(folder) / f'{name}.db'}"
            engines[name] = database(url, indexed, args.log)
        seconds: dict[str, list[float]] = {"with": [], "without": []}
        for i, body in enumerate(bodies):
            for name in ("with", "without") if i % 2 == 0 else ("without", "with"):
                engine, plan_id = engines[name]
                t0 = time.perf_counter()
                report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
                seconds[name].append(time.perf_counter() - t0)
        for engine, _ in engines.values():
            engine.dispose()
    ms = {name: 1000 * statistics.median(values) for name, values in seconds.items()}
    backend = "PostgreSQL" if args.postgres else "SQLite"
    print(f"{backend}, {args.log} audit entries stored, {args.reports} part reports into each:")
    print(f"  with rcb audit's indexes     median {ms['with']:7.2f} ms")
    print(f"  without them                 median {ms['without']:7.2f} ms")
    print(f"  ratio with / without         {ms['with'] / ms['without']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
