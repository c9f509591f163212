"""Each machine speaks for a tool by its newest plans (supervisor.fleet.window, db.fleet_window),
on SQLite and PostgreSQL: what a new plan's prior reads, what ``rcb fleet show`` says, what an
export carries and what an import holds."""

from __future__ import annotations

from sqlalchemy.orm import Session
from test_fleet_db import _learned

from api.cli.main import app
from api.services.fleet_models import exclude_from_fleet, import_tool
from api.services.read.fleet import fleet_members
from db.engine import make_engine
from db.fleet import fleet_evidence, local_evidence
from db.fleet_imported import imported_evidence
from db.fleet_models import export_models
from supervisor.fleet.window import PLANS_PER_MACHINE, newest_plans

from conftest import engine_url
from migrated import migrated

#: Plans of lathe-0 beyond its window, by name, oldest first.
OLD = ("w-0", "w-1")


def _plans(engine) -> set[str]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        return {item.plan for item in local_evidence(session=session, tool_names=["VCMR331"])}


def _lathe_0(engine, plans: int) -> dict[str, int]:  # type: ignore[no-untyped-def]
    """``plans`` plans of lathe-0, one part each: their ids by name, oldest first."""
    return {name: _learned(engine, name, 0, 1) for name in (f"w-{i}" for i in range(plans))}


def test_a_machine_speaks_by_its_newest_plans_and_one_taken_out_lets_an_older_in(engine) -> None:
    assert PLANS_PER_MACHINE == 10
    ids = _lathe_0(engine, 12)
    names = list(ids)
    _learned(engine, "other", 1, 1)
    assert _plans(engine) == {*names[2:], "other"}
    page = fleet_members(engine=engine, tool="VCMR331")["plans"]
    out = {p["plan"]: p["out"] for p in page}
    assert [out[n] for n in OLD] == ["older than lathe-0's 10 newest plans with it"] * 2
    assert all(out[n] == "" for n in [*names[2:], "other"])
    with Session(engine) as session:  # the rule in memory picks the same plans
        learned = fleet_evidence(session=session, tool_names=["VCMR331"])
    assert newest_plans(learned) == learned
    exclude_from_fleet(engine=engine, plan_id=ids["w-11"], machine=None, reason="wrong bar stock")
    assert _plans(engine) == {*names[1:11], "other"}  # w-11 out, w-1 back in
    page = fleet_members(engine=engine, tool="VCMR331")["plans"]
    out = {p["plan"]: p["out"] for p in page}
    assert out["w-1"] == "" and out["w-0"].startswith("older than lathe-0's")
    assert out["w-11"].startswith("taken out by")


def test_an_export_carries_the_newest_plans_and_an_import_keeps_the_newest(engine, tmp_path):
    """An export reads what a new plan reads. Imported first with w-0 … w-9 and then with w-2 …
    w-11, another database holds twelve plans of lathe-0 and speaks by the ten it imported
    last."""
    names = list(_lathe_0(engine, 10))
    with Session(engine) as session:
        first = export_models(session=session, tool="VCMR331")
    names += [f"w-{i}" for i in (10, 11)]
    for name in names[10:]:
        _learned(engine, name, 0, 1)
    with Session(engine) as session:
        second = export_models(session=session, tool="VCMR331")
    assert {item["plan"] for item in second["learned"]} == set(names[2:])
    url = f"sqlite:///{tmp_path / 'other.db'}"
    migrated(url)
    other = make_engine(url)
    for document in (first, second):
        import_tool(engine=other, data=document, source="plant one")
    machines = {item.machine for item in _imported(other)}
    assert len(machines) == 1
    assert {item.plan for item in _imported(other)} == set(names[2:])
    other.dispose()


def _imported(engine):  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        return [item for _, item in imported_evidence(session=session, tool_names=["VCMR331"])]


def test_newest_first_the_plans_in_the_fleet_come_first_and_page_down(engine, runner) -> None:
    """A year's plant (audited): at 1000 plans on a tool, ``rcb fleet show``'s first page, by
    id from the first, was all "older than ... newest plans", the fleet on the last pages."""
    ids = _lathe_0(engine, 12)
    names = list(ids)
    first = fleet_members(engine=engine, tool="VCMR331", page_size=5, newest=True)
    assert [p["plan"] for p in first["plans"]] == names[::-1][:5]
    assert all(p["in_fleet"] for p in first["plans"]) and first["next_cursor"] == (f"n{ids['w-7']}")
    rest = fleet_members(
        engine=engine, tool="VCMR331", cursor=first["next_cursor"], page_size=10, newest=True
    )
    assert [p["plan"] for p in rest["plans"]] == names[::-1][5:]  # w-6 .. w-0, none twice
    assert [p["in_fleet"] for p in rest["plans"]][-2:] == [False, False]  # OLD, the oldest
    url = engine_url(engine)
    args = ["fleet", "show", "VCMR331", "--newest", "--limit", "5", "--db", url]
    shown = runner.invoke(app, args, env={"COLUMNS": "80"})
    assert shown.exit_code == 0, shown.output
    assert f"--cursor n{ids['w-7']} --limit 5 --newest" in shown.output  # the next page's
    other = ["fleet", "show", "VCMR331", "--cursor", f"n{ids['w-7']}", "--db", url]
    wrong = runner.invoke(app, other)
    assert (wrong.exit_code, wrong.output) == (
        2,
        f"rcb: error: --cursor = 'n{ids['w-7']}': continues a page made with --newest: send it"
        " so\n",
    )
