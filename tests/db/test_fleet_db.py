"""The fleet prior through the database (issue 32): plans on two machines learn, a third starts
from them, on SQLite and PostgreSQL; the fleet is read in the same statements for any count."""

from __future__ import annotations

import copy
import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from sqlalchemy import event, func, select
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services.fleet_models import export_tool, import_tool
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine
from db.fleet import fleet_evidence
from db.fleet_law import tool_law
from db.fleet_left_out import left_out
from db.fleet_members import members
from db.identity import database_id
from models.errors import InputError
from supervisor.inputs.plan import plan_from_mapping
from supervisor.rcb.state import RcbSettings
from supervisor.virtual.fleet import noise_seed, sample_fleet
from supervisor.virtual.simulate import run_part

from conftest import engine_url, stored_state
from migrated import migrated

LEARN = RcbSettings(strategy="learn")


def _body(name: str, machine: str) -> dict[str, Any]:
    body = copy.deepcopy(BODY)
    body["name"], body["machine"]["name"] = name, machine
    return body


#: The virtual fleet the plans run on (supervisor.virtual.fleet: one law per tool, a ln K
#: offset per machine): scenario 11, four machines.
FLEET = sample_fleet(plan_from_mapping(BODY), 11, 4)


def _learned(  # type: ignore[no-untyped-def]
    engine, name: str, machine: int, parts: int, prior: str = "catalogue"
) -> int:
    """A plan on machine ``machine`` of :data:`FLEET` that made ``parts`` parts with learn."""
    body = _body(name, f"lathe-{machine}")
    plan_id = int(create_plan(engine=engine, body=body, settings=LEARN, prior=prior).body["id"])
    _made(engine, plan_id, machine, name, parts)
    return plan_id


def _made(engine, plan_id: int, machine: int, name: str, parts: int) -> None:  # type: ignore[no-untyped-def]
    """``parts`` parts of plan ``plan_id`` on machine ``machine``, serials ``name-1`` …"""
    state = stored_state(engine, plan_id)
    rng = np.random.default_rng(noise_seed(11, machine))
    for i in range(parts):
        outcome = run_part(
            FLEET[machine], {op.name: op.setpoint for op in state.setpoints.operations}, rng
        )
        body = outcome.report(f"{name}-{i + 1}", state.version)
        assert report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).status == 201
        state = stored_state(engine, plan_id)


def test_a_new_plan_starts_from_two_machines_and_says_so(engine) -> None:
    _learned(engine, "fleet-a", 0, 12)
    _learned(engine, "fleet-b", 1, 12)
    fleet = create_plan(engine=engine, body=_body("fleet-c", "lathe-3"), settings=LEARN).body
    catalogue = create_plan(
        engine=engine, body=_body("fleet-d", "lathe-4"), settings=LEARN, prior="catalogue"
    ).body
    assert (fleet["prior"], catalogue["prior"]) == ("fleet", "catalogue")
    assert fleet["cycle_time_min"] < catalogue["cycle_time_min"]
    assert catalogue["provenance"] == {}
    lines = [p for ps in fleet["provenance"].values() for p in ps]
    assert {p["quantity"] for p in lines} == {"force_N", "roughness_um"}
    assert all(p["plans"] == ["fleet-a", "fleet-b"] for p in lines)
    assert all(p["machines"] == ["lathe-0", "lathe-1"] for p in lines)
    # 12 parts on each machine, per operation of the tool: CNMG432RN one, VCMR331 two
    assert {p["readings"] for p in fleet["provenance"]["rough-od"]} == {24}
    assert {p["readings"] for p in fleet["provenance"]["rough-grooves"]} == {48}
    assert lines[0]["text"].startswith(f"{lines[0]['quantity']}: prior from 2 plans on 2 machines")
    # the stored plan starts where it was created: its state holds the priors, and learns on
    state = stored_state(engine, fleet["id"])
    assert set(state.priors) == {
        (op, p["quantity"]) for op, ps in fleet["provenance"].items() for p in ps
    }
    assert state.posterior == state.priors
    bodies, _ = _reports(1, seed=5, settings=LEARN)
    assert (
        report_part(engine=engine, plan_id=fleet["id"], report=parse_report(bodies[0])).status
        == 201
    )


#: The fleet's reads: a new plan's evidence, and a page of ``rcb fleet show``.
READS: dict[str, Callable[[Session], Sequence[object]]] = {
    "evidence": lambda s: fleet_evidence(session=s, tool_names=["CNMG432RN", "VCMR331"]),
    "members": lambda s: members(session=s, tool="CNMG432RN", after_id=0, limit=100),
    "law": lambda s: tool_law(session=s, tool="CNMG432RN"),
    # what the fleet left out of a new plan's tools (a list: nothing left out is an answer)
    "left_out": lambda s: [left_out(session=s, tool_names=["CNMG432RN", "VCMR331"])],
}


def _executed(engine, read: Callable[[Session], Sequence[object]]) -> list[tuple[str, Any]]:  # type: ignore[no-untyped-def]
    """The statements, with their parameters, that ``read`` sends (it must find something)."""
    sent: list[tuple[str, Any]] = []

    def seen(*args: Any) -> None:
        sent.append((args[2], args[3]))

    event.listen(engine, "before_cursor_execute", seen)
    try:
        with Session(engine) as session:
            assert read(session)
    finally:
        event.remove(engine, "before_cursor_execute", seen)
    return sent


@pytest.mark.parametrize("read", sorted(READS))
def test_the_fleet_is_read_in_the_same_statements_for_two_plans_as_for_four(
    engine, read: str
) -> None:
    _learned(engine, "n-a", 0, 2)
    _learned(engine, "n-b", 1, 2)
    two = len(_executed(engine, READS[read]))
    _learned(engine, "n-c", 2, 2)
    _learned(engine, "n-d", 3, 2)
    assert len(_executed(engine, READS[read])) == two


def test_a_fleet_prior_needs_a_fleet_and_learn(engine) -> None:
    with pytest.raises(InputError) as caught:
        create_plan(engine=engine, body=_body("x", "lathe-x"), settings=LEARN, prior="fleet")
    assert caught.value.field == "prior"
    _learned(engine, "fleet-a", 0, 2)
    with pytest.raises(InputError, match="only learn"):
        create_plan(
            engine=engine,
            body=_body("y", "lathe-y"),
            settings=RcbSettings(strategy="ivester"),
            prior="fleet",
        )
    ivester = create_plan(
        engine=engine, body=_body("z", "lathe-z"), settings=RcbSettings(strategy="ivester")
    ).body
    assert ivester["prior"] == "catalogue"  # the default for a strategy that does not learn
    # exponents known exactly: was refused as "no learn plan in the fleet has measured" (prior)
    with pytest.raises(InputError) as fixed:
        create_plan(
            engine=engine,
            body=_body("e", "lathe-e"),
            settings=RcbSettings(strategy="learn", exponent_sd=0.0),
            prior="fleet",
        )
    assert (fixed.value.field, fixed.value.value) == ("exponent_sd", 0.0)


def test_rcb_plans_create_prior_fleet_without_a_fleet_says_so_plainly(engine, runner) -> None:
    """The option named as typed, its value not its enum's repr (``prior = <Prior.fleet: 'fleet'>``
    before)."""
    example = Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml"
    url = engine_url(engine)
    done = runner.invoke(app, ["plans", "create", str(example), "--prior", "fleet", "--db", url])
    assert done.exit_code == 2
    assert "rcb: error: --prior = 'fleet': no learn plan in the fleet has measured" in done.output
    assert "rcb fleet show TOOL" in done.output and "Traceback" not in done.output


def test_exported_models_imported_into_a_fresh_database_give_the_same_prior(
    engine, tmp_path
) -> None:
    """A second plant: every tool's learned models, exported and imported into an empty
    SQLite database, make the same fleet prior for the same new plan, to the last bit."""
    _learned(engine, "fleet-a", 0, 6)
    _learned(engine, "fleet-b", 1, 6)
    url = f"sqlite:///{tmp_path / 'second.db'}"
    migrated(url)
    second = make_engine(url)
    tools = sorted({op["tool"] for op in BODY["operations"]})
    for tool in tools:
        document = export_tool(engine=engine, tool=tool)
        json.dumps(document)  # it travels as JSON
        assert import_tool(engine=second, data=document, source=f"{tool}.json").status == 201
    here = create_plan(engine=engine, body=_body("fleet-c", "lathe-2"), settings=LEARN).body
    there = create_plan(engine=second, body=_body("fleet-c", "lathe-2"), settings=LEARN).body
    assert there["prior"] == "fleet"
    assert there["operations"] == here["operations"]
    # the same, but for the machines: there, each is named with the database it is in
    with Session(engine) as session:
        suffix = "@" + database_id(session=session)[:8]
    assert _named_as_here(there["provenance"], suffix) == here["provenance"]
    # the chains' evidence travels too: the same noise prior (supervisor.fleet.noise)
    assert _named_as_here(there["noise_provenance"], suffix) == here["noise_provenance"] != []
    assert stored_state(second, there["id"]).priors == stored_state(engine, here["id"]).priors
    assert (
        stored_state(second, there["id"]).noise_priors
        == stored_state(engine, here["id"]).noise_priors
    )
    second.dispose()


def _named_as_here(provenance: Any, suffix: str) -> Any:
    """``provenance`` with every machine's and plan's ``suffix`` (each must carry it) taken off.

    An imported plan is named as its machine is (``fleet-a@6f1c2a3b``): a second plant's plan
    of the same name is another plan (tests/db/test_fleet_imported_plan_names.py).
    """
    if isinstance(provenance, dict):
        return {k: _named_as_here(v, suffix) for k, v in provenance.items()}
    if isinstance(provenance, list):
        return [_named_as_here(v, suffix) for v in provenance]
    if isinstance(provenance, str) and provenance.startswith(("lathe-", "fleet-")):
        assert provenance.endswith(suffix), provenance
        return provenance.removesuffix(suffix)
    return provenance


def test_a_document_that_is_not_one_stores_nothing(engine) -> None:
    _learned(engine, "fleet-a", 0, 2)
    document = export_tool(engine=engine, tool="VCMR331")
    document["learned"][-1]["posterior"]["mean"] = [1.0]  # sizes that do not match
    with pytest.raises(InputError) as caught:
        import_tool(engine=engine, data=document, source="bad.json")
    assert caught.value.field.endswith(".posterior.cov")
    with Session(engine) as session:
        assert session.scalar(select(func.count()).select_from(t.ImportedModel)) == 0


def test_rcb_models_export_and_import_at_the_cli(engine, tmp_path, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    backend_url = engine_url(engine)
    out = tmp_path / "vcmr331.json"
    done = runner.invoke(
        app, ["models", "export", "VCMR331", "--out", str(out), "--db", backend_url]
    )
    assert done.exit_code == 0, done.output
    assert "4 learned models of VCMR331 written" in done.output  # 2 operations x 2 quantities
    second = f"sqlite:///{tmp_path / 'second.db'}"
    migrated(second)
    done = runner.invoke(app, ["models", "import", str(out), "--db", second])
    assert done.exit_code == 0
    assert "rcb: 4 learned models stored from vcmr331.json (4 new)" in done.output
    done = runner.invoke(app, ["models", "import", str(out), "--db", second])  # again
    assert done.exit_code == 0 and (
        "0 learned models stored from vcmr331.json (4 already held, the same or with more"
        " readings)" in " ".join(done.output.split())
    )
    assert max(len(line) for line in done.output.splitlines()) <= 80
    (tmp_path / "bad.json").write_text('{"format": "x"}', encoding="utf-8")
    done = runner.invoke(app, ["models", "import", str(tmp_path / "bad.json"), "--db", second])
    assert done.exit_code == 2
    assert (
        "document.format = 'x': must be one of rcb-fleet-models/1, rcb-fleet-models/2"
        in done.output
    )
    assert "Traceback" not in done.output


def test_the_report_says_what_the_models_started_from(engine, tmp_path, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    create_plan(engine=engine, body=_body("fleet-c", "lathe-2"), settings=LEARN)
    url = engine_url(engine)
    pages = {}
    for plan in ("fleet-a", "fleet-c"):
        out = tmp_path / f"{plan}.html"
        done = runner.invoke(app, ["report", plan, "--db", url, "--out", str(out)])
        assert done.exit_code == 0, done.output
        pages[plan] = out.read_text(encoding="utf-8")
    assert "<dd>the tools&#x27; catalogue models</dd>" in pages["fleet-a"]
    assert "<dd>the fleet: 2 plans on 2 machines, between-machine spread" in pages["fleet-c"]
    # the operations' spread of the two inserts run twice, pooled into the others' (0.9 %)
    assert "%, between a machine&#x27;s operations 0.9-1.0 % (rcb plans show" in pages["fleet-c"]


def test_plans_create_says_where_the_catalogue_band_still_holds_the_start(capsys) -> None:
    """A fleet prior no narrower than the band (two machines at the default spread, a 7 %
    band: ``docs/try-a-machine.md``'s lathes) starts at the catalogue's setpoint, since the
    faster holds; ``rcb plans create`` says so instead of seeming to ignore the prior."""
    from api.cli.plans import _say_band_held

    ops = [
        {"name": "rough-od", "robust_by": "band"},
        {"name": "rough-grooves", "robust_by": "cone"},
        {"name": "finish-od", "robust_by": "band"},  # no fleet prior: nothing to say
    ]
    _say_band_held({"operations": ops, "provenance": {"rough-od": [], "rough-grooves": []}})
    assert capsys.readouterr().err == (  # within 80 columns
        "rcb: rough-od: the first setpoint is the catalogue band's, the faster: the\n"
        "  fleet's prior is not narrower there yet (more machines behind it narrow it)\n"
    )
    _say_band_held({"operations": ops[1:2], "provenance": {"rough-grooves": []}})
    assert capsys.readouterr().err == ""
