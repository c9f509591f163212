"""A plan from the fleet starts its measuring chains from the fleet's noise, and a chain noisier
than the fleet's lets it go, on SQLite and PostgreSQL (issue 32, :mod:`supervisor.fleet.noise`,
:mod:`supervisor.rcb.noise_check`, :mod:`db.fleet_noise`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy.orm import Session
from test_fleet_db import FLEET, LEARN, _body, _learned

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan, replan
from api.services.read import current_setpoints, get_plan
from db.fleet import fleet_evidence
from supervisor.fleet.noise import noise_priors
from supervisor.inputs.plan import plan_from_mapping
from supervisor.virtual.fleet import noise_seed
from supervisor.virtual.simulate import run_part

from conftest import engine_url, stored_state

PLAN = plan_from_mapping(_body("fleet-n", "lathe-3"))


def _fleet_plan(engine: Any) -> int:
    """Plan fleet-c on machine 3 after plans on machines 0 and 1 learned 12 parts each."""
    _learned(engine, "fleet-a", 0, 12)
    _learned(engine, "fleet-b", 1, 12)
    made = create_plan(engine=engine, body=_body("fleet-c", "lathe-3"), settings=LEARN)
    return int(made.body["id"])


def _report(engine: Any, plan_id: int, serial: str, rng: np.random.Generator, extra: float) -> None:
    """A part of machine 3; each roughness reading moved by ``N(0, (extra σ)²)`` more noise
    than its reported ``u = 2σ`` says: a profilometer ``√(1 + extra²)`` x noisier."""
    state = stored_state(engine, plan_id)
    outcome = run_part(FLEET[3], {op.name: op.setpoint for op in state.setpoints.operations}, rng)
    operations = []
    for op, measured in outcome.measurements.items():
        readings = {}
        for q, m in measured.items():
            value = m.value
            if q == "roughness_um":
                value *= float(np.exp(extra * rng.standard_normal() * m.uncertainty / 2 / m.value))
            readings[q] = {"value": value, "uncertainty": m.uncertainty}
        operations.append({"name": op, "measurements": readings})
    body = {"serial": serial, "setpoint_version": state.version, "operations": operations}
    assert report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).status == 201


def test_a_plan_from_the_fleet_starts_its_chains_from_the_fleets_noise(engine, runner) -> None:
    """The new plan's noise prior is the fleet's chains' (the same as from the evidence
    directly), stored, loaded, answered by the plan and its setpoints and shown by ``rcb plans
    show`` at 80 columns; its honest chains keep it over three parts."""
    plan_id = _fleet_plan(engine)
    with Session(engine) as session:
        learned = fleet_evidence(session=session, tool_names=PLAN.tools)
    expected = noise_priors([item for item in learned if item.plan != "fleet-c"])
    assert set(expected) == {"force_N", "roughness_um"}
    assert {q: p.machines for q, p in expected.items()} == dict.fromkeys(
        expected, ("lathe-0", "lathe-1")
    )
    state = stored_state(engine, plan_id)
    assert state.noise_priors == {q: p.belief for q, p in expected.items()}
    for answer in (
        get_plan(engine=engine, plan_id=plan_id),
        current_setpoints(engine=engine, plan_id=plan_id),
    ):
        lines = {p["quantity"]: p for p in answer["noise_provenance"]}
        assert set(lines) == set(expected)
        for q, p in expected.items():
            assert lines[q]["text"] == p.describe() and lines[q]["let_go_by_part"] is None
            assert 0.8 < lines[q]["noise_scale"] < 1.3  # the virtual chains are honest
    rng = np.random.default_rng(noise_seed(11, 3))
    for i in range(3):
        _report(engine, plan_id, f"c-{i + 1}", rng, 0.0)
    assert stored_state(engine, plan_id).noise_priors == state.noise_priors
    url = engine_url(engine)
    shown = runner.invoke(app, ["plans", "show", "fleet-c", "--db", url], env={"COLUMNS": "80"})
    assert shown.exit_code == 0, shown.output
    assert "noise prior of each measuring chain" in shown.output
    tables = [line for line in shown.output.splitlines() if not line.startswith("rcb: ")]
    assert [line for line in tables if len(line) > 80] == []  # the closing message wraps


def test_a_chain_noisier_than_the_fleets_lets_its_noise_prior_go(engine) -> None:
    """Roughness read by a profilometer 3.2 x noisier than its ``u``: the first part cannot
    tell (its innovations are the machine's offset), a later one lets the roughness chain's
    noise prior go and says so; force keeps the fleet's; a reset of the bands does not bring
    it back."""
    plan_id = _fleet_plan(engine)
    rng = np.random.default_rng(noise_seed(11, 3))
    serial = ""
    for i in range(6):
        serial = f"c-{i + 1}"
        _report(engine, plan_id, serial, rng, 3.0)
        if "roughness_um" not in stored_state(engine, plan_id).noise_priors:
            break
    state = stored_state(engine, plan_id)
    assert set(state.noise_priors) == {"force_N"} and serial != "c-1"
    lines = {p["quantity"]: p for p in get_plan(engine=engine, plan_id=plan_id)["noise_provenance"]}
    assert lines["roughness_um"]["let_go_by_part"] == serial
    assert (
        f"; let go by part {serial}: this machine's chain reads noisier"
        in (lines["roughness_um"]["text"])
    )
    assert lines["force_N"]["let_go_by_part"] is None
    assert replan(engine=engine, plan_id=plan_id, changes={"reset_bands": True}).status == 201
    assert set(stored_state(engine, plan_id).noise_priors) == {"force_N"}
