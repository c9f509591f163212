"""``rcb fleet show TOOL``: which plans make new plans' fleet priors and why the others do not
(issue 32), a page at a time, by index seeks (SQLite and PostgreSQL; the same statements for
any count: ``test_fleet_db``)."""

from __future__ import annotations

import json
import re
from typing import Any

from sqlalchemy.orm import Session
from test_fleet_db import LEARN, READS, _body, _executed, _learned

from api.cli.main import app
from api.services.fleet_models import exclude_from_fleet
from api.services.plans import create_plan
from db.engine import make_engine
from db.fleet import fleet_evidence
from supervisor.rcb.state import RcbSettings

from conftest import engine_url
from migrated import migrated


def _show(runner, url: str, *args: str) -> Any:  # type: ignore[no-untyped-def]
    return runner.invoke(app, ["fleet", "show", *args, "--db", url], env={"COLUMNS": "80"})


def test_the_fleet_of_a_tool_says_who_is_in_and_why_the_others_are_not(engine, runner) -> None:
    """fleet-a learned and is in; fleet-b learned but its machine was taken out; fleet-c runs
    RCB's band law (no posterior); fleet-d is new (no part yet); what each learned."""
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-1", reason="loose spindle")
    create_plan(
        engine=engine, body=_body("fleet-c", "lathe-2"), settings=RcbSettings(strategy="ivester")
    )
    create_plan(engine=engine, body=_body("fleet-d", "lathe-3"), settings=LEARN)
    url = engine_url(engine)
    shown = _show(runner, url, "VCMR331")
    assert shown.exit_code == 0, shown.output
    lines = shown.output.splitlines()  # but a command printed whole on its own, to copy
    assert max(len(line) for line in lines if not line.startswith("  rcb ")) <= 80
    text = " ".join(shown.output.split())
    for said in (
        "1 fleet-a lathe-0 8 yes",  # 2 operations x 2 quantities x 2 parts
        "no: machine lathe-1 taken out by",
        "loose spindle",
        "no: strategy",
        "no: no part reported",
        f"rcb: what they learned of its law: rcb fleet law VCMR331 --db {url}",  # its --db
    ):
        assert said in text, said
    page = json.loads(_show(runner, url, "VCMR331", "--json").stdout)
    assert [(m["plan"], m["readings"], bool(m["out"])) for m in page["plans"]] == [
        ("fleet-a", 8, False),
        ("fleet-b", 8, True),
        ("fleet-c", 0, True),
        ("fleet-d", 0, True),
    ]
    assert page["plans"][0]["operations"] == ["rough-grooves", "rough-contour"]
    with Session(engine) as session:  # the list and the prior agree on who is in the fleet
        behind = {item.plan for item in fleet_evidence(session=session, tool_names=["VCMR331"])}
    assert behind == {m["plan"] for m in page["plans"] if m["in_fleet"]} == {"fleet-a"}
    first = json.loads(_show(runner, url, "VCMR331", "--json", "--limit", "3").stdout)
    assert [m["plan"] for m in first["plans"]] == ["fleet-a", "fleet-b", "fleet-c"]
    rest = _show(runner, url, "VCMR331", "--json", "--cursor", first["next_cursor"])
    assert [m["plan"] for m in json.loads(rest.stdout)["plans"]] == ["fleet-d"]
    assert (
        "rcb fleet show VCMR331 --cursor 3 --limit 3"
        in _show(runner, url, "VCMR331", "--limit", "3").output
    )


def test_rcb_fleet_show_names_what_is_wrong(engine, runner) -> None:
    url = engine_url(engine)
    unused = _show(runner, url, "CNMG432RN")
    assert unused.exit_code == 0 and "no stored plan uses CNMG432RN" in unused.output
    _learned(engine, "fleet-a", 0, 1)
    for args, said in (
        (["NOPE"], "TOOL = 'NOPE'"),
        (["VCMR331", "--limit", "0"], "--limit = 0"),
        (["VCMR331", "--cursor", "x"], "--cursor = 'x'"),
    ):
        done = _show(runner, url, *args)
        assert done.exit_code != 0 and said in done.output, done.output
        assert "Traceback" not in done.output
    last = _show(runner, url, "VCMR331", "--cursor", "1")  # past the last plan: an empty page
    assert last.exit_code == 0 and "no stored plan uses" not in last.output


def test_the_fleet_is_read_by_index_seeks_alone(tmp_path) -> None:
    """SQLite's query plan of every statement the fleet's reads make (a new plan's evidence,
    the plans' changes, what it left out, a page of ``rcb fleet show``): no table is scanned
    whole, so no cost grows with the parts or exclusions a plant has made (before alembic
    0018, every operation row scanned ``fleet_exclusions``); what is scanned is the windows
    that pick each machine's newest plans, which SQLite builds from index searches, and the plant's
    machines, each walked for its newest plans with a tool (alembic 0027). No statement
    seeks a tool's operations by the tool alone: that walked every plan that ever used it
    (13 s for a prior over 9 760 plans before 0027, docs/benchmarks.md)."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-1", reason="loose spindle")
    statements = [sent for read in READS.values() for sent in _executed(engine, read)]
    plans = []
    with engine.connect() as connection:
        raw = connection.connection.driver_connection
        for statement, parameters in statements:
            plans += [row[-1] for row in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters)]
    engine.dispose()
    assert any("fleet_exclusions" in line for line in plans)
    # the windows of each machine's newest plans (db.fleet_window) are scanned as SQLite
    # made them, from index searches; no table is scanned
    scanned = [line for line in plans if line.startswith("SCAN")]
    # and the imported machines, stepped through one seek each (a recursive CTE from one
    # constant row a tool, alembic 0031); and the window again, a plan once a tool, for what
    # the fleet left out of it (db.fleet_left_out)
    derived = (
        r"SCAN (anon_\d+|\(subquery-\d+\)|chosen|window_machine"
        r"|CONSTANT ROW|last_machine|imported_machines|left_window)"
    )
    assert scanned and all(re.fullmatch(derived, s) for s in scanned), sorted(set(scanned))
    by_tool_alone = r"ix_operations_tool\w* \(tool_id=\?\)"
    assert not [line for line in plans if re.search(by_tool_alone, line)]
    assert any("ix_operations_tool_machine_plan (tool_id=? AND machine_id=?)" in p for p in plans)
