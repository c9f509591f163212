"""History at scale (issue 17, item 1): a page of ``GET /plans/{id}/history`` costs the same
at 20 and at 400 setpoint versions, pages chain by cursor, and each version shows the models
that the old full walk showed. SQLite and PostgreSQL; the REST paging through ``rcb serve``."""

from __future__ import annotations

from typing import Any

import pytest
from scale_support import PLAN_ID
from sqlalchemy import event, select
from sqlalchemy.orm import Session
from test_service import BODY

from api.services import read as queries
from api.services.plans import create_plan
from db import tables as t
from db.engine import reader

from conftest import renamed, report_at
from migrated import migrated

#: Tables whose rows grow with the plan's life: a page may seek in them, never scan them.
HISTORY_TABLES = ("operation_model_versions", "setpoint_versions", "setpoints", "parts")


class Statements:
    """The SQL statements an engine runs while counting, with their parameters."""

    def __init__(self, engine: Any) -> None:
        self.engine = engine
        self.seen: list[tuple[str, Any]] = []
        self.on = False
        for each in {engine, reader(engine)}:  # reads go through the read pool's engine
            event.listen(each, "before_cursor_execute", self._hear)

    def _hear(self, conn, cursor, statement, parameters, context, executemany) -> None:
        if self.on:
            self.seen.append((statement, parameters))

    def run(self, **kwargs: Any) -> tuple[dict[str, Any], list[tuple[str, Any]]]:
        """One history page and the statements it ran."""
        self.seen, self.on = [], True
        try:
            page = queries.plan_history(engine=self.engine, **kwargs)
        finally:
            self.on = False
        return page, self.seen

    def scans(self, statements: list[tuple[str, Any]]) -> list[str]:
        """SQLite: the query-plan lines that read a history table whole (none is allowed)."""
        out = []
        with self.engine.connect() as connection:
            raw = connection.connection.driver_connection
            for statement, parameters in statements:
                if not statement.lstrip().upper().startswith("SELECT"):
                    continue
                for row in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters):
                    detail = row[-1]
                    if detail.startswith("SCAN") and any(
                        f"SCAN {name}" in detail or f"SCAN {name} " in detail
                        for name in HISTORY_TABLES
                    ):
                        out.append(detail)
        return out


def _walk_of_old(engine: Any, plan_id: int) -> dict[int, dict[str, dict[str, Any]]]:
    """The models in force per version as the old code computed them: every model row for
    every setpoint version (the quadratic walk issue 17 reports), written out as reference."""
    with Session(engine) as session:
        versions = session.scalars(
            select(t.SetpointVersion).where(t.SetpointVersion.plan_id == plan_id)
        ).all()
        found = session.execute(
            select(t.OperationModelVersion, t.Operation.name)
            .join(t.Operation, t.OperationModelVersion.operation_id == t.Operation.id)
            .where(t.Operation.plan_id == plan_id)
            .order_by(
                t.Operation.position,
                t.OperationModelVersion.quantity,
                t.OperationModelVersion.version,
            )
        ).all()
        # the rows' columns read once (not 160,000 ORM attribute reads per version at 400)
        rows = [(m.part_id, name, m.quantity, (m.K, m.dK, m.version)) for m, name in found]
        out = {}
        for version in versions:
            in_force: dict[str, dict[str, Any]] = {}
            at = version.part_id
            for part_id, name, quantity, model in rows:
                if part_id is None or (at is not None and part_id <= at):
                    in_force.setdefault(name, {})[quantity] = model
            out[version.version] = {
                name: {q: {"K": K, "dK": dK, "version": v} for q, (K, dK, v) in models.items()}
                for name, models in in_force.items()
            }
    return out


def _models(page: dict[str, Any]) -> dict[int, dict[str, dict[str, Any]]]:
    return {
        v["version"]: {o["name"]: o["models"] for o in v["operations"]} for v in page["versions"]
    }


def test_a_history_page_costs_the_same_at_20_and_at_400_versions(bayes_history):
    # bayes: a version per part, as in the 2031-version plan; 19 and 399 parts
    plan_id = PLAN_ID
    costs = {}
    for size in (20, 400):
        engine = bayes_history.at(size - 1)  # the plan's first version and one per part
        counter = Statements(engine)
        sqlite = engine.dialect.name == "sqlite"
        first, first_sql = counter.run(plan_id=plan_id, page_size=10)
        last, last_sql = counter.run(plan_id=plan_id, page_size=10, newest=True)
        assert [v["version"] for v in first["versions"]] == list(range(1, 11))
        assert first["next_cursor"] == "10"
        assert [v["version"] for v in last["versions"]] == list(range(size - 9, size + 1))
        assert last["next_cursor"] == f"n{size - 9}"  # a cursor that says it pages back
        reference = _walk_of_old(engine, plan_id)
        for page in (first, last):
            assert _models(page) == {v: reference[v] for v in _models(page)}
        costs[size] = (len(first_sql), len(last_sql))
        if sqlite:
            assert counter.scans(first_sql + last_sql) == []
    assert costs[20] == costs[400]  # the statements per page do not grow with the history
    # counted (this listened to the writers' engine alone once, and counted nothing): the plan,
    # its operations, the versions, their setpoints, the models in force, the replans' actors
    selects = [s for s, _ in first_sql if s.lstrip().upper().startswith("SELECT")]
    assert 3 <= len(selects) <= 8
    # the pages chain: forward from version 1 and backward from now, each version once
    forward, cursor = [], None
    while True:
        page = queries.plan_history(engine=engine, plan_id=plan_id, cursor=cursor, page_size=64)
        forward += page["versions"]
        if (cursor := page["next_cursor"]) is None:
            break
    backward, cursor = [], None
    while True:
        page = queries.plan_history(
            engine=engine, plan_id=plan_id, cursor=cursor, page_size=64, newest=True
        )
        backward = page["versions"] + backward
        if (cursor := page["next_cursor"]) is None:
            break
    assert [v["version"] for v in forward] == list(range(1, 401))
    assert forward == backward
    assert {v["version"]: {o["name"]: o["models"] for o in v["operations"]} for v in forward} == (
        _walk_of_old(engine, plan_id)
    )
    assert [v["serial"] for v in forward[1:3]] == ["SN-0001", "SN-0002"]


def test_a_history_page_out_of_bounds_is_refused(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    for size in (0, queries.MAX_PAGE + 1):
        with pytest.raises(ValueError, match="limit"):
            queries.plan_history(engine=engine, plan_id=plan_id, page_size=size)
    with pytest.raises(ValueError, match="cursor"):
        queries.plan_history(engine=engine, plan_id=plan_id, cursor="-1")
    for bad in ("n", "nn3", "n-3", "3n", "n99999999999"):
        with pytest.raises(ValueError, match="cursor"):
            queries.plan_history(engine=engine, plan_id=plan_id, cursor=bad, newest=True)


def _with_three_parts(c, body) -> int:  # type: ignore[no-untyped-def]
    """An ivester plan of ``body`` with three parts reported (four setpoint versions)."""
    plan_id = c.post("/plans", json=body, params={"strategy": "ivester"}).json()["id"]
    setpoints = c.get(f"/plans/{plan_id}/setpoints").json()
    for i in range(3):
        setpoints = c.post(
            f"/plans/{plan_id}/parts",
            json=report_at(f"P{i}", setpoints),
            headers={"Idempotency-Key": f"p-{plan_id}-{i}"},
        ).json()
    return int(plan_id)


def test_rest_history_pages_with_a_cursor_either_way(server):
    with server.client("engineer") as c:
        plan_id = _with_three_parts(c, BODY)
        url = f"/plans/{plan_id}/history"
        whole = c.get(url).json()  # no parameter: the first page of 100, as before plus a cursor
        assert [v["version"] for v in whole["versions"]] == [1, 2, 3, 4]
        assert whole["next_cursor"] is None
        pages = []
        for params in (
            {"limit": 2},
            {"limit": 2, "cursor": "2"},
            {"limit": 2, "order": "newest"},
            {"limit": 2, "order": "newest", "cursor": "n3"},
        ):
            r = c.get(url, params=params)
            assert r.status_code == 200, r.text
            pages.append(([v["version"] for v in r.json()["versions"]], r.json()["next_cursor"]))
        assert pages == [([1, 2], "2"), ([3, 4], None), ([3, 4], "n3"), ([1, 2], None)]
        assert c.get(url, params={"limit": 2}).json()["versions"] == whole["versions"][:2]
        for bad, field in (
            ({"limit": 0}, "limit"),
            ({"limit": 501}, "limit"),
            ({"cursor": "x"}, "cursor"),
            ({"order": "sideways"}, "order"),
        ):
            r = c.get(url, params=bad)
            assert r.status_code == 422 and r.json()["field"] == field, r.text


def test_a_history_cursor_of_one_order_is_refused_in_the_other(server):
    """``order=newest&cursor=3`` (a cursor of an ``oldest`` page) gave the versions before 3:
    a page the other way, without a word. As for parts, the cursor says its order."""
    with server.client("engineer") as c:
        plan_id = _with_three_parts(c, renamed(BODY))
        url = f"/plans/{plan_id}/history"
        forward = c.get(url, params={"limit": 2}).json()["next_cursor"]
        backward = c.get(url, params={"limit": 2, "order": "newest"}).json()["next_cursor"]
        assert (forward, backward) == ("2", "n3")
        for params, made_in in (
            ({"cursor": forward, "order": "newest"}, "oldest"),
            ({"cursor": backward}, "newest"),  # order=oldest by default
            ({"cursor": backward, "order": "oldest"}, "newest"),
        ):
            r = c.get(url, params=params)
            assert r.status_code == 422, r.text
            assert r.headers["content-type"] == "application/problem+json"
            body = r.json()
            assert (body["field"], body["value"]) == ("cursor", params["cursor"])
            assert f"continues order={made_in}: send it with order={made_in}" in body["detail"]
        for bad in ("n", "nn3", "n-3", "3n", "n99999999999"):
            r = c.get(url, params={"cursor": bad, "order": "newest"})
            assert r.status_code == 422 and r.json()["field"] == "cursor", r.text
        # each order still chains through every version, a version once
        for order, mark, chained in (("oldest", "", [1, 2, 3, 4]), ("newest", "n", [4, 3, 2, 1])):
            seen, cursor = [], None
            while True:
                params = {"limit": 1, "order": order, **({"cursor": cursor} if cursor else {})}
                page = c.get(url, params=params).json()
                seen += [v["version"] for v in page["versions"]]
                if (cursor := page["next_cursor"]) is None:
                    break
                assert cursor == f"{mark}{seen[-1]}"
            assert seen == chained


def test_the_report_lists_the_newest_200_versions_and_summarises_older_ones(tmp_path):
    """A plan's page does not grow with its setpoint history: 1000 versions read as 800
    summarised per 100 and the newest 200 one by one (the same as 250 versions, plus 7 rows)."""
    import xml.etree.ElementTree as ET

    from api.report.html import render_html_report
    from db.engine import make_engine

    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    plan = queries.get_plan(engine=engine, plan_id=plan_id)
    start = queries.plan_history(engine=engine, plan_id=plan_id)
    engine.dispose()
    model = start["versions"][0]

    def history(n):
        versions = [
            {**model, "version": i, "cause": "part", "serial": f"S{i}", "part_id": i}
            for i in range(1, n + 1)
        ]
        return {**start, "versions": versions}

    def rows(n):
        page = render_html_report(plan, history(n), [])
        root = ET.fromstring(page.removeprefix("<!DOCTYPE html>\n"))
        table = root.find(".//table[@id='history']")
        return page, ["".join(r.itertext()) for r in table.findall("tbody/tr")]

    small, few = rows(150)
    big, many = rows(1000)
    assert len(few) == 150 and few[0].startswith("1part")
    assert len(many) == 8 + 200
    assert many[0].startswith("1–100100 versionsS1 … S100")
    assert many[7].startswith("701–800100 versions")
    assert many[8].startswith("801part") and many[-1].startswith("1000part")
    assert len(big.encode()) - len(small.encode()) < 60_000
