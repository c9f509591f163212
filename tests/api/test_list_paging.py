"""Every list by page (issue 17): plans, tools, model versions; the models in force.

A page costs the same SQL statements with few and with many rows, reads no history table
whole (SQLite's query plans), and the pages chain by cursor to exactly the whole list. A key
scoped to plans gets full pages of its own plans only. SQLite and PostgreSQL; REST through a
real ``rcb serve``, the web view's "next" link, and ``rcb plans``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import httpx
import pytest
from scale_support import PLAN_ID
from sqlalchemy import event, select, text
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.keys import create_key
from api.services.parts import report_part
from api.services.plans import create_plan
from db import library
from db import tables as t
from db.engine import make_engine, reader
from models.catalogue import catalogue
from models.powerlaw import PowerLawModel
from models.tool import Tool

from conftest import report_at

#: Tables whose rows grow with the plant's life: a page may seek in them, never scan them.
GROWING = ("plans", "tools", "tool_models", "operation_model_versions", "parts")


class Counter:
    """The SQL statements an engine runs during a call, with their parameters."""

    def __init__(self, engine: Any) -> None:
        self.engine, self.seen, self.on = engine, [], False
        for each in {engine, reader(engine)}:  # reads go through the read pool's engine
            event.listen(each, "before_cursor_execute", self._hear)

    def _hear(self, conn, cursor, statement, parameters, context, executemany) -> None:
        if self.on:
            self.seen.append((statement, parameters))

    def run(self, call: Callable[..., dict[str, Any]], **kwargs: Any) -> dict[str, Any]:
        self.seen, self.on = [], True
        try:
            return call(engine=self.engine, **kwargs)
        finally:
            self.on = False

    def selects(self) -> int:
        """How many of the statements were queries (not SQLite's deferred ``BEGIN``)."""
        return sum(s.lstrip().upper().startswith("SELECT") for s, _ in self.seen)

    def scans(self) -> list[str]:
        """SQLite: the query-plan lines that read a growing table whole (none is allowed)."""
        if self.engine.dialect.name != "sqlite":
            return []
        out = []
        with self.engine.connect() as connection:
            raw = connection.connection.driver_connection
            for statement, parameters in self.seen:
                if not statement.lstrip().upper().startswith("SELECT"):
                    continue
                for row in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters):
                    if any(row[-1].startswith(f"SCAN {name}") for name in GROWING):
                        out.append(row[-1])
        return out


def _chain(call: Callable[..., dict[str, Any]], key: str, **kwargs: Any) -> list[Any]:
    """Every item of a list, page after page by ``next_cursor``."""
    items, cursor = [], None
    while True:
        page = call(cursor=cursor, **kwargs)
        items += page[key]
        if (cursor := page["next_cursor"]) is None:
            return items


def _more_plans(engine: Any, like: int, count: int) -> list[int]:
    """``count`` copies of plan ``like``'s row (the list reads only the plans table)."""
    with Session(engine) as session, session.begin():
        row = session.get(t.Plan, like)
        copies = [
            t.Plan(
                name=f"copy {count}.{i}",  # a name names one plan
                machine_id=row.machine_id,
                body=row.body,
                settings=row.settings,
                current_setpoint_version=1,
            )
            for i in range(count)
        ]
        session.add_all(copies)
        session.flush()
        return [c.id for c in copies]


def test_a_plans_page_costs_the_same_at_3_and_at_300_plans(engine):
    first = create_plan(engine=engine, body=BODY).body["id"]
    bodies, _ = _reports(3)
    for body in bodies:
        assert report_part(engine=engine, plan_id=first, report=parse_report(body)).status == 201
    ids = [first, *_more_plans(engine, first, 2)]
    counter, costs = Counter(engine), {}
    for size in (3, 300):
        if size == 300:
            ids += _more_plans(engine, first, 297)
        page = counter.run(queries.list_plans, page_size=2)
        assert [p["id"] for p in page["plans"]] == ids[:2]
        assert [p["parts"] for p in page["plans"]] == [3, 0]  # counted per plan
        assert page["next_cursor"] == str(ids[1])
        costs[size] = counter.selects()
        assert counter.scans() == []
    assert costs[3] == costs[300] == 1
    assert [p["id"] for p in _chain(queries.list_plans, "plans", engine=engine, page_size=64)] == (
        ids
    )
    # a scoped key: filtered in the query, so every page is full and names only its plans
    scope = frozenset({ids[5], ids[100], ids[299], 10**6})
    pages = []
    cursor = None
    while True:
        page = queries.list_plans(engine=engine, cursor=cursor, page_size=1, only=scope)
        pages.append([p["id"] for p in page["plans"]])
        if (cursor := page["next_cursor"]) is None:
            break
    assert pages == [[ids[5]], [ids[100]], [ids[299]]]
    last = queries.list_plans(engine=engine, cursor=str(ids[-1]))
    assert last == {"plans": [], "next_cursor": None}


def _tool(name: str) -> Tool:
    model = PowerLawModel("force_N", 1000.0, 100.0, {"feed_mm_rev": 0.8}, "test", "")
    return Tool(name, "turning", {"force_N": model}, "", "", "test")


def test_a_tools_page_merges_the_catalogue_and_costs_the_same_at_5_and_300_stored(engine):
    packaged = sorted(catalogue())
    # names around and among the catalogue's, in code-point order: upper before lower case,
    # "Z" before "a", non-ASCII last; one stored tool takes a catalogue name's place
    names = ["A-0", "Zz", "a-lower", "Ärger", packaged[0] + "-x"]
    with Session(engine) as session, session.begin():
        for name in names:
            library.add_tool(session=session, tool=_tool(name))
    counter, costs = Counter(engine), {}
    for size in (5, 300):
        if size == 300:
            more = [f"T{i:04d}" for i in range(295)]
            with Session(engine) as session, session.begin():
                for name in more:
                    library.add_tool(session=session, tool=_tool(name))
            names += more
        expected = sorted({*packaged, *names})
        page = counter.run(queries.list_tools, page_size=3)
        assert [x["name"] for x in page["tools"]] == expected[:3]
        costs[size] = counter.selects()
        assert counter.scans() == []
        everything = _chain(queries.list_tools, "tools", engine=engine, page_size=7)
        assert [x["name"] for x in everything] == expected
        assert {x["name"]: x["source"] for x in everything}["A-0"] == "test"
    assert costs[5] == costs[300] == 2
    if engine.dialect.name == "postgresql":  # migration 0008: code-point order whatever the
        with engine.connect() as connection:  # database's collation
            collation = connection.execute(
                text(
                    "SELECT collation_name FROM information_schema.columns "
                    "WHERE table_name = 'tools' AND column_name = 'name'"
                )
            ).scalar()
        assert collation == "C"


def test_model_versions_page_by_version_and_the_models_in_force_by_seek(bayes_history):
    plan_id, costs = PLAN_ID, {}  # bayes: a model version per part and quantity
    for size in (5, 60):
        engine = bayes_history.at(size - 1)  # the plan's first version and one per part
        counter = Counter(engine)
        with Session(engine) as session:  # the reference: every row, read whole
            rows = session.execute(
                select(t.OperationModelVersion, t.Operation.position, t.Operation.name)
                .join(t.Operation, t.OperationModelVersion.operation_id == t.Operation.id)
                .where(t.Operation.plan_id == plan_id)
            ).all()
        order = sorted(rows, key=lambda r: (r[0].version, r[1], r[0].quantity))
        reference = [(r[2], r[0].quantity, r[0].version, r[0].dK) for r in order]
        page = counter.run(queries.model_versions, plan_id=plan_id, page_size=10)
        got = [(v["operation"], v["quantity"], v["version"], v["dK"]) for v in page["versions"]]
        assert got == reference[:10]
        costs[size] = counter.selects()
        assert counter.scans() == []
        newest = {}
        for name, quantity, version, dk in reference:
            newest[(name, quantity)] = (version, dk)
        in_force = counter.run(queries.models_in_force, plan_id=plan_id)
        assert {
            (op["name"], q): (m["version"], m["dK"])
            for op in in_force["operations"]
            for q, m in op["models"].items()
        } == newest
        assert counter.scans() == []
        assert counter.selects() == 5  # plan, operations, their ids, pairs, the newest rows
    assert costs[5] == costs[60] == 5
    assert len(reference) > 60 * 3  # a version per part and quantity: the longest list
    whole = _chain(queries.model_versions, "versions", engine=engine, plan_id=plan_id, page_size=37)
    assert [(v["operation"], v["quantity"], v["version"], v["dK"]) for v in whole] == reference
    assert [v["serial"] for v in whole if v["version"] == 2][0] == "SN-0001"
    one = _chain(
        queries.model_versions,
        "versions",
        engine=engine,
        plan_id=plan_id,
        operation="rough-od",
        quantity="force_N",
        page_size=8,
    )
    assert [v["version"] for v in one] == list(range(1, 61))


def test_bad_pages_are_refused_naming_the_field(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    calls = (
        (queries.list_plans, {}),
        (queries.list_tools, {}),
        (queries.model_versions, {"plan_id": plan_id}),
    )
    for call, kwargs in calls:
        for size in (0, queries.MAX_PAGE + 1):
            with pytest.raises(ValueError, match="limit"):
                call(engine=engine, page_size=size, **kwargs)
        for cursor in ("x", "-1", "e30", "WzEsMiwiYSJd" * 200):
            with pytest.raises(ValueError, match="cursor"):
                call(engine=engine, cursor=cursor, **kwargs)


def test_rest_lists_page_with_a_cursor_and_a_scoped_key_gets_full_pages(server):
    with server.client("engineer") as c:
        ids = [c.post("/plans", json={**BODY, "name": f"paged {i}"}).json()["id"] for i in range(3)]
        setpoints = c.get(f"/plans/{ids[0]}/setpoints").json()
        for i in range(2):
            setpoints = c.post(
                f"/plans/{ids[0]}/parts",
                json=report_at(f"L{i}", setpoints),
                headers={"Idempotency-Key": f"l-{ids[0]}-{i}"},
            ).json()
        plans = _rest_chain(c, "/plans", "plans", limit=1)
        assert [p["id"] for p in plans][-3:] == ids
        assert plans == c.get("/plans").json()["plans"]  # default: a page of 100
        assert c.get("/plans").json()["next_cursor"] is None
        tools = [x["name"] for x in _rest_chain(c, "/tools", "tools", limit=2)]
        assert tools == sorted(tools) and set(catalogue()) <= set(tools)
        assert tools == [x["name"] for x in c.get("/tools", params={"limit": 500}).json()["tools"]]
        url = f"/plans/{ids[0]}/models/versions"
        versions = _rest_chain(c, url, "versions", limit=3)
        assert versions == c.get(url).json()["versions"]
        keys = [(v["version"], v["operation"], v["quantity"]) for v in versions]
        assert keys[0][0] == 1 and len(set(keys)) == len(keys) > 3
        assert [k[0] for k in keys] == sorted(k[0] for k in keys)
        for path in ("/plans", "/tools", url):
            for bad, field in (({"limit": 0}, "limit"), ({"limit": 501}, "limit")):
                r = c.get(path, params=bad)
                assert r.status_code == 422 and r.json()["field"] == field, r.text
            for cursor in ("x!", "WzEsMiwiYSJd" * 200):
                r = c.get(path, params={"cursor": cursor})
                assert r.status_code == 422 and r.json()["field"] == "cursor", r.text
        r = c.get("/tools", params={"cursor": "eA"})  # base64url of "x": no list of a name
        assert r.status_code == 422 and r.json()["field"] == "cursor", r.text
    engine = make_engine(server.url)
    scoped = create_key(engine=engine, role="viewer", plans=[ids[0], ids[2]])["key"]
    engine.dispose()
    headers = {"Authorization": f"Bearer {scoped}"}
    with httpx.Client(base_url=server.base, headers=headers, timeout=60.0) as s:
        first = s.get("/plans", params={"limit": 1}).json()
        assert [p["id"] for p in first["plans"]] == [ids[0]]
        second = s.get("/plans", params={"limit": 1, "cursor": first["next_cursor"]}).json()
        assert [p["id"] for p in second["plans"]] == [ids[2]]  # not short, not plan 2
        assert second["next_cursor"] is None
        assert first["plans"][0]["parts"] == 2


def _rest_chain(client: httpx.Client, url: str, key: str, **params: Any) -> list[Any]:
    items, cursor = [], None
    while True:
        r = client.get(url, params={**params, **({"cursor": cursor} if cursor else {})})
        assert r.status_code == 200, r.text
        items += r.json()[key]
        if (cursor := r.json()["next_cursor"]) is None:
            return items


def test_the_web_view_lists_plans_by_page_with_a_next_link(server):
    with server.client("engineer") as c:
        first = c.post("/plans", json={**BODY, "name": "ui"}).json()["id"]
    engine = make_engine(server.url)
    _more_plans(engine, first, 120)  # more than a page of the view (100)
    engine.dispose()
    with server.client("engineer") as c:
        every = [p["id"] for p in _rest_chain(c, "/plans", "plans", limit=500)]
    ui = server.base.removesuffix("/api/v1") + "/ui"
    with httpx.Client(timeout=60.0) as browser:
        signed_in = browser.post(f"{ui}/login", data={"key": server.keys["viewer"]})
        assert signed_in.status_code == 303, signed_in.text  # its session's cookie is kept
        shown, pages, url = [], [], f"{ui}/"
        while url:
            r = browser.get(url)
            assert r.status_code == 200, r.text
            pages.append([int(i) for i in _attribute(r.text, 'data-plan="')])
            shown += pages[-1]
            link = _attribute(r.text, 'href="/ui/?cursor=')
            url = f"{ui}/?cursor={link[0]}" if link else ""
        assert shown == every and len(pages[0]) == 100 and len(pages) == -(-len(every) // 100)
        bad = browser.get(f"{ui}/", params={"cursor": "x"})
        assert bad.status_code == 400 and "cursor" in bad.text


def _attribute(page: str, prefix: str) -> list[str]:
    out, at = [], page.find(prefix)
    while at >= 0:
        start = at + len(prefix)
        out.append(page[start : page.find('"', start)])
        at = page.find(prefix, start)
    return out


def test_rcb_plans_pages_and_streams(runner, engine):
    if engine.dialect.name != "sqlite":
        pytest.skip("the CLI reads the same queries; SQLite is enough here")
    url = str(engine.url)
    first = create_plan(engine=engine, body=BODY).body["id"]
    ids = [first, *_more_plans(engine, first, 4)]
    page = runner.invoke(app, ["plans", "--db", url, "--limit", "2"])
    assert page.exit_code == 0, page.output
    assert f"rcb plans --cursor {ids[1]} --limit 2" in page.stderr
    rest = runner.invoke(app, ["plans", "--db", url, "--cursor", str(ids[1]), "--json"])
    assert rest.exit_code == 0, rest.output
    lines = rest.stdout.splitlines()
    assert [json.loads(line.rstrip(","))["id"] for line in lines[1:-1]] == ids[2:]
    assert json.loads(rest.stdout) == {
        "plans": [json.loads(line.rstrip(",")) for line in lines[1:-1]],
        "next_cursor": None,
    }
    one = runner.invoke(app, ["plans", "--db", url, "--limit", "1", "--json"])
    assert json.loads(one.stdout)["next_cursor"] == str(ids[0])
    for args, field in ((["--limit", "0"], "--limit"), (["--cursor", "x"], "--cursor")):
        bad = runner.invoke(app, ["plans", "--db", url, *args])
        assert bad.exit_code == 2 and f"rcb: error: {field} = " in bad.stderr, bad.output
        assert "Traceback" not in bad.output
