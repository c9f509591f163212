"""A report's reads and page at scale (issue 17): the statements and rows read for the page
are the same at 20 and at 400 parts, on SQLite and PostgreSQL, and the record the SQL
aggregates give equals the one computed from every part and version
(api/report/full_record.py, the former code path)."""

from __future__ import annotations

import re
from typing import Any

import pytest
from scale_support import PLAN_ID, Copied
from sqlalchemy import event, text
from test_service import BODY

from api.report import full_record as full_module
from api.report import html_history
from api.report.full_record import full_record
from api.report.html import render_record
from api.services import read as queries
from api.services.plans import create_plan
from api.services.read import record as record_module
from api.services.read.record import report_record

LAST = 5


class Reads:
    """The SELECT statements an engine runs while on, with the rows each returns."""

    def __init__(self, engine: Any) -> None:
        self.engine, self.seen, self.on = engine, [], False
        event.listen(engine, "before_cursor_execute", self._hear)

    def _hear(self, conn, cursor, statement, parameters, context, executemany) -> None:
        if self.on:
            self.seen.append((statement, parameters))

    def run(self, **kwargs: Any) -> tuple[dict[str, Any], list[tuple[str, int]]]:
        self.seen, self.on = [], True
        try:
            out = report_record(engine=self.engine, **kwargs)
        finally:
            self.on = False
        rows = []
        with self.engine.connect() as connection:
            raw = connection.connection.driver_connection
            for statement, parameters in self.seen:
                cursor = raw.cursor()
                cursor.execute(statement, parameters)
                rows.append((statement, len(cursor.fetchall())))
                cursor.close()
        return out, rows


@pytest.fixture
def small_pages(monkeypatch):
    """10 versions listed and one summary row, so that both sizes fill every part of the page."""
    for module in (record_module, full_module, html_history):
        monkeypatch.setattr(module, "HISTORY_ROWS", 10)
    monkeypatch.setattr(record_module, "SUMMARY_ROWS", 1)


def test_the_report_reads_the_same_at_20_and_at_400_parts(bayes_history, small_pages):
    plan_id = PLAN_ID  # bayes: a setpoint version per part
    seen = {}
    for size in (20, 400):
        engine = bayes_history.at(size)
        reads = Reads(engine)
        got, rows = reads.run(plan_id=plan_id, last=LAST)
        seen[size] = rows
        # the same record as computed from every part and version
        plan = queries.get_plan(engine=engine, plan_id=plan_id)
        history = queries.full_history(engine=engine, plan_id=plan_id)
        parts = queries.all_parts(engine=engine, plan_id=plan_id)
        want = full_record(plan, history, parts, LAST)
        assert got["totals"] == want["totals"]
        assert got["totals"]["parts"] == size
        assert [p["serial"] for p in got["parts"]] == [p["serial"] for p in parts[-LAST:]]
        assert [
            (s["first"]["version"], s["last"]["version"], s["versions"]) for s in got["summaries"]
        ] == [
            (s["first"]["version"], s["last"]["version"], s["versions"]) for s in want["summaries"]
        ]
        assert got["summaries"][0]["first"]["version"] == 1
        assert got["summaries"][-1]["last"]["version"] == size + 1 - 10  # then 10 listed
        key = lambda d: (d["operation"], d["quantity"])  # noqa: E731
        assert sorted(got["last_decisions"], key=key) == sorted(want["last_decisions"], key=key)
        assert got["marks"] == {k: v for k, v in want["marks"].items() if k in got["marks"]}
        listed = html_history.listed_versions(got["history"])
        assert [v["version"] for v in listed] == list(range(size - 8, size + 2))
    statements = {size: [s for s, _ in rows] for size, rows in seen.items()}
    assert statements[20] == statements[400]  # the same statements, whatever the history
    assert len(statements[400]) <= 16
    counts = {size: [n for s, n in rows if "flagged" not in s] for size, rows in seen.items()}
    assert counts[20] == counts[400]  # the same rows, but the data-dependent flags and notes
    marks = {size: [n for s, n in rows if "rcb_decisions.flagged OR" in s] for size in seen}
    assert all(n <= 10 * 20 for ns in marks.values() for n in ns)


def test_a_long_plan_page_stays_small(tmp_path, tmp_path_factory):
    """The demonstration plan after 400 parts: the page plots the last 100 and stays under
    400 kB (measured: 259 kB at 0 parts, 362 kB at 100, 381 kB at 1000; 6.9 MB at 1000
    before issue 17). With a setpoint version per part (bayes) it is 420 kB: under 1 MB."""
    for strategy, limit in ((None, 400_000), ("bayes", 1_000_000)):
        history = Copied(tmp_path_factory, tmp_path, strategy)  # 400 parts, shared
        page = render_record(report_record(engine=history.at(400), plan_id=PLAN_ID))
        history.close()
        size = len(page.encode("utf-8"))
        assert size <= limit, (strategy, size)
        assert "the last 100 parts, from SN-0301" in page
        assert page.count("<svg") == 1 + 4 * 6
        assert re.search(r"\bnan\b", page, re.I) is None


def test_last_out_of_bounds_is_refused_naming_the_field(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    for bad in (0, record_module.MAX_LAST + 1):
        with pytest.raises(ValueError, match="--last"):
            report_record(engine=engine, plan_id=plan_id, last=bad)
    with engine.connect() as c:  # nothing was written
        assert c.execute(text("SELECT count(*) FROM parts")).scalar() == 0
