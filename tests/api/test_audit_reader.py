"""``rcb audit``: the audit log read newest first, by page, filtered (issue 32's verdicts
and every write were stored with no reader but SQL).

On SQLite and PostgreSQL: the entries real commands leave, in order, with their actor; each
filter; pages that chain to exactly the whole log, ties of time included (Hypothesis);
``--since`` as an age and as a time with an offset; every bad option a one-line exit 2; a
filtered page read through its index (SQLite's query plan), not the whole log; a plan's page
through the plan's index and the action's (its machine's fleet entries), a page of each.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy import delete, event, insert
from sqlalchemy.orm import Session

from api.services.audit_log import audit_page, query_of
from api.services.since import since_of
from db import audit
from db.audit_read import AuditQuery
from db.engine import make_engine, reader

from conftest import ROOT, engine_url, invoke
from migrated import migrated

PLAN = ROOT / "examples" / "ivester_demo_part.toml"
#: A fixed moment the seeded entries are dated from.
T0 = datetime(2026, 11, 30, 8, 0, tzinfo=UTC)


def _json(runner, url: str, *args: str) -> dict:
    done = invoke(runner, "audit", "--db", url, "--json", *args)
    assert done.exit_code == 0, done.stderr
    return json.loads(done.stdout)


def test_real_commands_are_read_back_newest_first_and_by_filter(runner, engine):
    url = engine_url(engine)
    steps = [
        ("plans", "create", str(PLAN), "--by", "ana"),
        ("keys", "create", "--role", "mes", "--by", "ana"),
        ("replan", "1", "--limit", "rough-od.force_N=1900", "--by", "bo"),
        ("fleet", "exclude", "--plan", "1", "--reason", "wrong bar stock", "--by", "bo"),
    ]
    for step in steps:
        assert invoke(runner, *step, "--db", url).exit_code == 0
    listed = _json(runner, url)["entries"]
    assert [(e["actor"], e["action"], e["target"]) for e in listed] == [
        ("cli:bo", "fleet exclude", "plan 1"),
        ("cli:bo", "replan", "plan 1"),
        ("cli:ana", "create key", "key 1"),
        ("cli:ana", "create plan", "plan ivester-demo-part"),
    ]
    assert [e["result"] for e in listed] == ["200", "201", "mes", "201"]
    assert listed[0]["detail"] == {"reason": "wrong bar stock"}  # why, as the engineer said
    only = _json(runner, url, "--action", "replan")["entries"]
    assert [(e["actor"], e["target"]) for e in only] == [("cli:bo", "plan 1")]
    by_ana = _json(runner, url, "--actor", "cli:ana")["entries"]
    assert [e["action"] for e in by_ana] == ["create key", "create plan"]
    assert _json(runner, url, "--actor", "cli:nobody") == {"entries": [], "next_cursor": None}

    table = invoke(runner, "audit", "--db", url, "--limit", "3")
    assert table.exit_code == 0
    shown = table.stdout.split()  # words: a narrow column wraps between them
    assert {"cli:bo", "fleet", "exclude", "replan", "mes"} <= set(shown)
    assert {"reason:", "wrong", "bar", "stock"} <= set(shown)  # the detail as key: value
    assert "ivester-demo-part" not in table.stdout  # the fourth entry is on the next page
    hint = table.stderr.split()
    assert hint[:5] == ["rcb:", "older", "entries:", "rcb", "audit"]
    assert hint[-4:] == ["--limit", "3", "--db", url]  # the database read, run as printed
    cursor = hint[hint.index("--cursor") + 1]
    rest = _json(runner, url, "--limit", "3", "--cursor", cursor)
    assert rest == {"entries": listed[3:], "next_cursor": None}


def _seed(engine, minutes: list[int], actions: list[str]) -> None:
    """Entries at ``T0`` + each minute (equal minutes: equal times), each of its action."""
    with Session(engine) as session, session.begin():
        session.execute(delete(audit.AUDIT))
        for n, (minute, action) in enumerate(zip(minutes, actions, strict=True)):
            row = audit.audit_row("cli:test", action, f"entry {n}", "ok", {"n": n})
            session.execute(insert(audit.AUDIT), {**row, "at": T0 + timedelta(minutes=minute)})


def _chained(engine, query: AuditQuery, limit: int) -> list[int]:
    """The ``n`` of every entry, page after page."""
    seen, cursor = [], None
    while True:
        page = audit_page(engine=engine, query=query, cursor=cursor, limit=limit)
        assert len(page["entries"]) <= limit
        seen += [e["detail"]["n"] for e in page["entries"]]
        if (cursor := page["next_cursor"]) is None:
            return seen


def _expected(minutes: list[int], actions: list[str], query: AuditQuery) -> list[int]:
    """Newest first, ties by insertion (id) newest first, as the reader promises."""
    kept = [
        n
        for n, (m, a) in enumerate(zip(minutes, actions, strict=True))
        if (query.action is None or a == query.action)
        and (query.since is None or T0 + timedelta(minutes=m) >= query.since)
    ]
    return sorted(kept, key=lambda n: (minutes[n], n), reverse=True)


def test_pages_chain_to_the_whole_log_with_ties_on_both_backends(engine):
    minutes = [0, 0, 1, 1, 1, 2, 5, 5, 3, 3, 9, 0, 1]  # out of order, ties: ids decide
    actions = ["replan", "report part"] * 6 + ["replan"]
    _seed(engine, minutes, actions)
    for query in (
        AuditQuery(),
        AuditQuery(action="replan"),
        AuditQuery(since=T0 + timedelta(minutes=1)),
        AuditQuery(action="report part", since=T0 + timedelta(minutes=3)),
    ):
        want = _expected(minutes, actions, query)
        for limit in (1, 2, 3, 5, 13, 14):
            assert _chained(engine, query, limit) == want, (query, limit)


@pytest.fixture(scope="module")
def sqlite_engine(tmp_path_factory):
    url = f"sqlite:///{tmp_path_factory.mktemp('audit') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    yield engine
    engine.dispose()


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    log=st.lists(st.tuples(st.integers(0, 4), st.sampled_from(["a", "b"])), max_size=25),
    limit=st.integers(1, 7),
    action=st.sampled_from([None, "a", "b"]),
    since=st.sampled_from([None, 0, 2, 5]),
)
def test_any_log_pages_to_exactly_its_entries(sqlite_engine, log, limit, action, since):
    minutes, actions = [m for m, _ in log], [a for _, a in log]
    _seed(sqlite_engine, minutes, actions)
    moment = None if since is None else T0 + timedelta(minutes=since)
    query = AuditQuery(action=action, since=moment)
    assert _chained(sqlite_engine, query, limit) == _expected(minutes, actions, query)


def test_since_takes_an_age_or_a_time_with_its_offset():
    now = datetime(2026, 12, 1, 12, 0, tzinfo=UTC)
    assert since_of("7d", now) == datetime(2026, 11, 24, 12, 0, tzinfo=UTC)
    assert since_of("90m", now) == datetime(2026, 12, 1, 10, 30, tzinfo=UTC)
    # 10:00 at +02:00 is 08:00 UTC (the stored times are UTC: not 10:00 UTC)
    assert since_of("2026-12-01T10:00+02:00") == datetime(2026, 12, 1, 8, 0, tzinfo=UTC)
    assert since_of("2026-12-01") == datetime(2026, 12, 1, 0, 0, tzinfo=UTC)


def test_since_with_an_offset_selects_by_the_utc_time(engine):
    _seed(engine, [0, 59, 61], ["x", "x", "x"])  # 08:00, 08:59, 09:01 UTC
    query = query_of(None, None, "2026-11-30T10:00+01:00")  # 09:00 UTC
    assert [e["detail"]["n"] for e in audit_page(engine=engine, query=query)["entries"]] == [2]


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--limit", "0"], "--limit = 0: must be between 1 and 500"),
        (["--limit", "501"], "--limit = 501"),
        (["--since", "yesterday"], "--since = 'yesterday': expected an age"),
        (["--since", "0d"], "--since = '0d'"),
        (["--since", "0001-01-01T00:00+05:00"], "--since = '0001-01-01T00:00+05:00': outside"),
        (["--since", "2" * 41], "--since = '" + "2" * 40 + "...': expected an age"),
        (["--cursor", "abc"], "--cursor = 'abc': not a cursor printed by rcb audit"),
        (["--cursor", "WyJ4IiwiMSJd"], "--cursor = 'WyJ4IiwiMSJd'"),  # ["x","1"]: no time
        (  # ["9999-12-31T23:59:59-05:00","1"]: the year 10000 in UTC (a traceback before)
            ["--cursor", "WyI5OTk5LTEyLTMxVDIzOjU5OjU5LTA1OjAwIiwiMSJd"],
            "--cursor = 'WyI5OTk5LTEyLTMxVDIzOjU5OjU5LTA1OjAwIiwiMSJd': not a cursor printed",
        ),
        (["--action", ""], "--action = '': 1 to 100 characters"),
        (["--actor", "x" * 201], "--actor = "),
    ],
)
def test_bad_options_are_one_line_naming_the_option(runner, tmp_path, args, named):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    done = invoke(runner, "audit", "--db", url, *args)
    assert done.exit_code == 2
    assert named in done.stderr and len(done.stderr.strip().splitlines()) == 1


def _plan_of(engine, query: AuditQuery, deep: bool = False) -> str:
    """SQLite's query plan of the page :func:`audit_page` reads, as it ran it.

    ``deep``: of the second page (below the first page's cursor), not the first.
    """
    cursor = audit_page(engine=engine, query=query, limit=1)["next_cursor"] if deep else None
    seen = []

    def hear(conn, cursor, statement, parameters, context, executemany) -> None:
        if statement.lstrip().upper().startswith("SELECT"):
            seen.append((statement, parameters))

    event.listen(reader(engine), "before_cursor_execute", hear)
    try:
        audit_page(engine=engine, query=query, cursor=cursor, limit=1)
    finally:
        event.remove(reader(engine), "before_cursor_execute", hear)
    ((statement, parameters),) = seen
    with engine.connect() as connection:
        raw = connection.connection.driver_connection
        return " | ".join(r[-1] for r in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters))


def test_a_filtered_page_reads_through_its_index(sqlite_engine):
    """SQLite's plans: each filter seeks its index; none reads the log whole."""
    _seed(sqlite_engine, [0, 1, 2], ["a", "b", "a"])
    plans = {
        name: _plan_of(sqlite_engine, query)
        for name, query in {
            "action": AuditQuery(action="a"),
            "actor": AuditQuery(actor="cli:test"),
            "since": AuditQuery(since=T0),
            "plan": AuditQuery(plan_id=1),
            "none": AuditQuery(),
        }.items()
    }
    assert "ix_audit_log_action_at" in plans["action"], plans
    assert "ix_audit_log_plan_id_at" in plans["plan"], plans
    assert "ix_audit_log_actor_at" in plans["actor"], plans
    assert "ix_audit_log_at" in plans["since"] and "ix_audit_log_at" in plans["none"], plans
    # a deeper page seeks below its cursor's time: it reads no more than the first
    assert "(action=? AND at<?)" in _plan_of(sqlite_engine, AuditQuery(action="a"), deep=True)
    assert "(at<?)" in _plan_of(sqlite_engine, AuditQuery(), deep=True)
    for name, plan in plans.items():
        assert not any(step.strip() == "SCAN audit_log" for step in plan.split("|")), plans
        if name != "plan":
            assert "TEMP B-TREE" not in plan, plans  # no sort of what was read: the index's order
    # a plan's page merges its own entries' and its machine's fleet entries' (action, at):
    # each reads its index down to a page (LIMIT), the sort is of that page, not of the history
    steps = [step.strip() for step in plans["plan"].split("|")]
    assert steps.count("SEARCH audit_log USING INDEX ix_audit_log_action_at (action=?)") == 2
    assert "MERGE (UNION ALL)" in steps and steps.count("USE TEMP B-TREE FOR ORDER BY") == 3
    sorted_ = [steps[i - 1] for i, step in enumerate(steps) if "B-TREE" in step]
    assert all(step.startswith("SCAN anon_") for step in sorted_), steps  # a page each
