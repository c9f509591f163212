"""The shop floor misbehaves, through a real ``rcb serve`` (issue 27's acceptance).

DESIGN.md, RCB, "The shop floor misbehaves", with the default strategy (``learn``) on the
demonstration plan, over REST on SQLite and PostgreSQL. A virtual machine
(:func:`supervisor.virtual.sampling.sample_machine`) is the truth: each part is made by
:func:`supervisor.virtual.simulate.run_part` at the setpoints in force (GET setpoints) and its
measurements posted with the version they were made with and the rough-od edge's age, as
:func:`supervisor.virtual.scenario.run_scenario` does in process.

1. A dropout (a reading at 10 % of the part before's) is quarantined: ``implausible_low``,
   held, not flagged, on the answer, the stored part and the history; no speed-up from it.
2. A +12 % step of every true maximum is a ``regime_change``, and the part after it, made on
   the stepped machine at the new setpoints, crosses no true limit.
3. A gross breach (6000 N on 2000 N) halts the plan; a replan with reset bands resumes.
4. Readings 3x noisier than their reported u leave a wider band than honest ones.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import tomllib
from collections.abc import Mapping
from typing import Any

import httpx
import numpy as np
import pytest

from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.virtual.machine import TrueProcess, VirtualMachine
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN, ROOT, renamed
from live import RCB, LiveServer

BODY = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
PLAN = load_plan(DEMO_PLAN)
#: The truth of every test: one virtual machine inside the plan's bands (and its noise seed).
SEED = 0
#: Parts the rough-od edge makes before it is changed (the plan's parts_per_edge).
EDGE_LIFE = 10
#: The measured quantities whose truth the step raises (every "max" model quantity).
STEPPED = ("force_N", "roughness_um", "spindle_current_A")
STEP = 1.12
U_N = 10.0  # the gross breach's force uncertainty [N]


# --------------------------------------------------------------------------- helpers


def _create(eng: httpx.Client) -> int:
    """A plan of the demonstration part with the default strategy (``learn``).

    From the catalogue: the module's server holds other learn plans of the same tools, whose
    learning would otherwise be this plan's fleet prior (issue 32); these tests are about one
    plan's own learning.
    """
    created = eng.post("/plans", json=renamed(BODY), params={"prior": "catalogue"})
    assert created.status_code == 201, created.text
    plan_id: int = created.json()["id"]
    assert eng.get(f"/plans/{plan_id}").json()["strategy"] == "learn"
    return plan_id


def _post(mes: httpx.Client, plan_id: int, body: dict[str, Any]) -> dict[str, Any]:
    key = f"shop-{plan_id}-{body['serial']}"
    answer = mes.post(f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": key})
    assert answer.status_code == 201, answer.text
    created: dict[str, Any] = answer.json()
    return created


def _setpoints(mes: httpx.Client, plan_id: int) -> dict[str, Any]:
    answer = mes.get(f"/plans/{plan_id}/setpoints")
    assert answer.status_code == 200, answer.text
    setpoints: dict[str, Any] = answer.json()
    return setpoints


def _made_at(setpoints: dict[str, Any]) -> dict[str, dict[str, float]]:
    """The cutting parameters of every operation, for :func:`run_part`."""
    return {op["name"]: op["setpoint"] for op in setpoints["operations"]}


def _operation(setpoints: dict[str, Any], name: str) -> dict[str, Any]:
    found: dict[str, Any] = next(op for op in setpoints["operations"] if op["name"] == name)
    return found


def _report(
    serial: str,
    version: int,
    measurements: Mapping[str, Mapping[str, Measurement]],
    age: int,
) -> dict[str, Any]:
    """A part report of ``measurements`` made with ``version``; rough-od's edge made ``age``."""
    return {
        "serial": serial,
        "setpoint_version": version,
        "operations": [
            {
                "name": name,
                "measurements": {
                    q: {"value": m.value, "uncertainty": m.uncertainty} for q, m in read.items()
                },
            }
            | ({"edge_parts": age} if name == "rough-od" else {})
            for name, read in measurements.items()
        ],
    }


def _update(updates: list[dict[str, Any]], operation: str, quantity: str) -> dict[str, Any]:
    (found,) = [u for u in updates if (u["operation"], u["quantity"]) == (operation, quantity)]
    return found


def _make_parts(
    mes: httpx.Client,
    plan_id: int,
    machine: VirtualMachine,
    rng: np.random.Generator,
    serials: range,
) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """Make and post one part per serial number at the setpoints in force, each crossing no
    true limit; the reports posted and their 201 answers."""
    posted = []
    for k in serials:
        setpoints = _setpoints(mes, plan_id)
        age = (k - 1) % EDGE_LIFE
        outcome = run_part(machine, _made_at(setpoints), rng, {"rough-od": age})
        assert outcome.violations == (), (k, outcome.violations)
        body = _report(f"SN-{k}", setpoints["setpoint_version"], outcome.measurements, age)
        posted.append((body, _post(mes, plan_id, body)))
    return posted


def _stepped(machine: VirtualMachine, factor: float) -> VirtualMachine:
    """``machine`` with every true maximum quantity's K multiplied by ``factor``."""
    processes = {}
    for name, process in machine.processes.items():
        models = dict(process.tool.models)
        for quantity in STEPPED:
            if quantity in models:
                models[quantity] = dataclasses.replace(
                    models[quantity], K=models[quantity].K * factor
                )
        tool = dataclasses.replace(process.tool, models=models)
        processes[name] = TrueProcess(name, tool)
    return VirtualMachine(machine.plan, processes, machine.uncertainty)


def _cli_history(url: str, plan_id: int) -> dict[str, Any]:
    """``rcb history PLAN --json`` on the server's database: the versions with their decisions."""
    done = subprocess.run(
        [str(RCB), "history", str(plan_id), "--db", url, "--json"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    history: dict[str, Any] = json.loads(done.stdout)
    return history


# --------------------------------------------------------------------------- 1. a dropout

#: Plausible parts made before the dropout.
PLAUSIBLE = 3


def _dropout(
    mes: httpx.Client, plan_id: int, only: bool
) -> tuple[list[dict[str, Any]], dict[str, Any], dict[str, Any], float]:
    """:data:`PLAUSIBLE` parts of the machine, then one whose rough-od force reads 10 % of the
    part before's, with the usual u.

    ``only``: the dropout is the report's only reading; else the part's other readings are the
    machine's. Returns the plausible reports, the setpoints the dropout part was made with, its
    report, and the reading before it [N].
    """
    machine = sample_machine(PLAN, SEED)
    rng = np.random.default_rng(SEED)
    posted = _make_parts(mes, plan_id, machine, rng, range(1, PLAUSIBLE + 1))
    assert not any(answer["halted"] for _, answer in posted)
    last = _operation(posted[-1][0], "rough-od")
    previous = float(last["measurements"]["force_N"]["value"])
    before = _setpoints(mes, plan_id)
    assert before["setpoint_version"] == posted[-1][1]["setpoint_version"]
    outcome = run_part(machine, _made_at(before), rng, {"rough-od": PLAUSIBLE})
    read = {name: dict(m) for name, m in outcome.measurements.items()}
    if only:
        read = {"rough-od": {}}
    read["rough-od"]["force_N"] = Measurement(0.1 * previous, machine.uncertainty["force_N"])
    body = _report("SN-DROP", before["setpoint_version"], read, PLAUSIBLE)
    return [body for body, _ in posted], before, body, previous


def _quarantined(update: dict[str, Any], previous: float) -> None:
    """The dropout's decision: held with the note, not flagged, its band untouched."""
    assert update["note"] == "implausible_low"
    assert update["action"] == "hold"
    assert update["flag"] is None and update["flagged"] is False
    assert update["measured"] == pytest.approx(0.1 * previous, rel=1e-12)
    assert update["band_after"] == update["band_before"]


def _stored_update(eng: httpx.Client, plan_id: int, serial: str) -> dict[str, Any]:
    parts = eng.get(f"/plans/{plan_id}/parts").json()["items"]
    (part,) = [p for p in parts if p["serial"] == serial]
    return _update(part["updates"], "rough-od", "force_N")


def test_a_dropout_alone_is_quarantined_and_moves_no_setpoint(server: LiveServer) -> None:
    with server.client("engineer") as eng, server.client("mes") as mes:
        plan_id = _create(eng)
        _, before, body, previous = _dropout(mes, plan_id, only=True)
        answer = _post(mes, plan_id, body)
        assert answer["halted"] is False
        (update,) = answer["updates"]
        assert (update["operation"], update["quantity"]) == ("rough-od", "force_N")
        _quarantined(update, previous)
        # nothing learned: the setpoint version does not move, rough-od is no faster
        assert answer["setpoint_version"] == before["setpoint_version"]
        after = _setpoints(mes, plan_id)
        assert after["setpoint_version"] == before["setpoint_version"]
        rough_before, rough_after = _operation(before, "rough-od"), _operation(after, "rough-od")
        assert rough_after["setpoint"] == rough_before["setpoint"]
        assert rough_after["mrr_cm3_min"] <= rough_before["mrr_cm3_min"]

        stored = _stored_update(eng, plan_id, "SN-DROP")
        assert (stored["note"], stored["action"], stored["flagged"]) == (
            "implausible_low",
            "hold",
            False,
        )
        history = eng.get(f"/plans/{plan_id}/history").json()["versions"]
        assert history[-1]["version"] == before["setpoint_version"]
        assert "SN-DROP" not in [v["serial"] for v in history]


def test_a_dropout_among_good_readings_is_quarantined_on_every_surface(
    server: LiveServer,
) -> None:
    """The other readings of the part move the setpoints; the dropout adds nothing to them:
    rough-od is where a twin plan puts it from the same report without the dropout."""
    with server.client("engineer") as eng, server.client("mes") as mes:
        plan_id = _create(eng)
        plausible, before, body, previous = _dropout(mes, plan_id, only=False)
        answer = _post(mes, plan_id, body)
        assert answer["halted"] is False
        _quarantined(_update(answer["updates"], "rough-od", "force_N"), previous)
        roughness = _update(answer["updates"], "rough-od", "roughness_um")
        assert roughness["note"] != "implausible_low"  # the part's good reading is learned
        after = _setpoints(mes, plan_id)
        assert after["setpoint_version"] == answer["setpoint_version"]

        stored = _stored_update(eng, plan_id, "SN-DROP")
        assert (stored["note"], stored["action"], stored["flagged"]) == (
            "implausible_low",
            "hold",
            False,
        )
        versions = _cli_history(server.url, plan_id)["versions"]
        (caused,) = [v for v in versions if v["serial"] == "SN-DROP"]
        (held,) = [
            d
            for d in caused["decisions"]
            if (d["operation"], d["quantity"]) == ("rough-od", "force_N")
        ]
        assert (held["note"], held["action"], held["flagged"]) == ("implausible_low", "hold", False)

        twin = _create(eng)
        for report in plausible:
            _post(mes, twin, report)
        assert _setpoints(mes, twin)["operations"] == before["operations"]
        without = json.loads(json.dumps(body))
        del _operation(without, "rough-od")["measurements"]["force_N"]
        _post(mes, twin, without)
        assert _operation(_setpoints(mes, twin), "rough-od") == _operation(after, "rough-od")


# --------------------------------------------------------------------------- 2. a +12 % step

#: Parts made on the machine before its step.
BEFORE_STEP = 8


def test_a_twelve_percent_step_is_a_regime_change_and_the_next_part_is_safe(
    server: LiveServer,
) -> None:
    machine = sample_machine(PLAN, SEED)
    stepped = _stepped(machine, STEP)
    rng = np.random.default_rng(SEED)
    with server.client("engineer") as eng, server.client("mes") as mes:
        plan_id = _create(eng)
        posted = _make_parts(mes, plan_id, machine, rng, range(1, BEFORE_STEP + 1))
        for _, answer in posted:
            assert answer["halted"] is False
            assert "regime_change" not in [u["note"] for u in answer["updates"]]

        before = _setpoints(mes, plan_id)
        made_at, age = _made_at(before), BEFORE_STEP % EDGE_LIFE
        truth = run_part(machine, made_at, np.random.default_rng(0), {"rough-od": age})
        outcome = run_part(stepped, made_at, rng, {"rough-od": age})
        for name, values in outcome.true_values.items():  # the step is the one asked for
            for quantity in ("force_N", "roughness_um"):
                assert values[quantity] == pytest.approx(STEP * truth.true_values[name][quantity])
        serial = BEFORE_STEP + 1
        body = _report(f"SN-{serial}", before["setpoint_version"], outcome.measurements, age)
        answer = _post(mes, plan_id, body)
        changed = [
            (u["operation"], u["quantity"])
            for u in answer["updates"]
            if u["note"] == "regime_change"
        ]
        assert ("rough-od", "force_N") in changed
        assert answer["halted"] is False

        after = _setpoints(mes, plan_id)
        assert after["setpoint_version"] == answer["setpoint_version"] > before["setpoint_version"]
        following = run_part(stepped, _made_at(after), rng, {"rough-od": serial % EDGE_LIFE})
        assert following.violations == ()


# --------------------------------------------------------------------------- 3. a gross breach


def test_a_gross_breach_halts_the_default_strategy_and_a_replan_resumes(
    server: LiveServer,
) -> None:
    with server.client("engineer") as eng, server.client("mes") as mes:
        plan_id = _create(eng)
        assert eng.get(f"/plans/{plan_id}").json()["settings"]["halt_over"] == 0.25
        body = {
            "serial": "SN-6000",
            "setpoint_version": 1,
            "operations": [
                {
                    "name": "rough-od",
                    "measurements": {"force_N": {"value": 6000.0, "uncertainty": U_N}},
                }
            ],
        }
        answer = _post(mes, plan_id, body)
        assert answer["halted"] is True
        assert answer["setpoint_version"] == 1  # the setpoints the part was made with stay
        assert [c["operation"] for c in answer["conflicts"]] == ["rough-od"]
        # (6000 − 10) / 2000 − 1 = 199.5 % past the 2000 N limit, more than halt_over 25 %
        named = "rough-od force_N measured 6000 is past its limit 2000 by 199.5 %"
        message = answer["conflicts"][0]["message"]
        assert named in message and "halt_over 25 %" in message
        breach = _update(answer["updates"], "rough-od", "force_N")
        assert breach["flag"] == "breach" and breach["flagged"] is True

        refused = mes.get(f"/plans/{plan_id}/setpoints")
        assert refused.status_code == 409, refused.text
        assert refused.headers["content-type"].startswith("application/problem+json")
        problem = refused.json()
        assert problem["code"] == "plan_halted" and problem["status"] == 409
        assert named in problem["detail"]
        assert problem["conflicts"] == answer["conflicts"]
        assert eng.get(f"/plans/{plan_id}").json()["status"] == "halted"

        resumed = eng.post(
            f"/plans/{plan_id}/replan",
            json={"reset_bands": True},
            headers={"Idempotency-Key": f"shop-resume-{plan_id}"},
        )
        assert resumed.status_code == 201, resumed.text
        assert resumed.json()["setpoint_version"] == 2
        again = _setpoints(mes, plan_id)
        assert again["setpoint_version"] == 2
        assert eng.get(f"/plans/{plan_id}").json()["status"] == "running"


# --------------------------------------------------------------------------- 4. noise 3x u

#: Parts of each plan; the scatter of the noisy plan's force readings, in their reported σ.
NOISY_PARTS, NOISE_SCALE = 15, 3.0


def _scattered(
    mes: httpx.Client, plan_id: int, machine: VirtualMachine, z: np.ndarray, scale: float
) -> dict[str, Any]:
    """:data:`NOISY_PARTS` parts whose readings scatter about the machine's truth at the
    setpoints in force: force by ``scale`` times its reported σ = u/2, roughness by its σ
    (``z``: the standard normal draws, part × operation × quantity); the last 201 answer."""
    u_force, u_finish = machine.uncertainty["force_N"], machine.uncertainty["roughness_um"]
    answer: dict[str, Any] = {}
    for k in range(1, NOISY_PARTS + 1):
        setpoints = _setpoints(mes, plan_id)
        age = (k - 1) % EDGE_LIFE
        truth = run_part(machine, _made_at(setpoints), np.random.default_rng(0), {"rough-od": age})
        read = {
            name: {
                "force_N": Measurement(
                    truth.true_values[name]["force_N"] + scale * u_force / 2 * z[k - 1, i, 0],
                    u_force,
                ),
                "roughness_um": Measurement(
                    truth.true_values[name]["roughness_um"] + u_finish / 2 * z[k - 1, i, 1],
                    u_finish,
                ),
            }
            for i, name in enumerate(op.name for op in PLAN.operations)
        }
        body = _report(f"SN-{k}", setpoints["setpoint_version"], read, age)
        answer = _post(mes, plan_id, body)
        assert answer["halted"] is False
    return answer


def _noisy_and_honest(
    server: LiveServer,
) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any], dict[str, Any]]:
    """Two plans fed the same parts of the same truth, force 3x noisier than its u on the
    first; the last 201 answers and the setpoints after them."""
    machine = sample_machine(PLAN, SEED)
    z = np.random.default_rng(SEED).standard_normal((NOISY_PARTS, len(PLAN.operations), 2))
    with server.client("engineer") as eng, server.client("mes") as mes:
        noisy, honest = _create(eng), _create(eng)
        loud = _scattered(mes, noisy, machine, z, NOISE_SCALE)
        calm = _scattered(mes, honest, machine, z, 1.0)
        return loud, calm, _setpoints(mes, noisy), _setpoints(mes, honest)


def test_readings_noisier_than_their_u_leave_a_wider_band(server: LiveServer) -> None:
    loud, calm, _, _ = _noisy_and_honest(server)
    for op in PLAN.operations:
        wide = _update(loud["updates"], op.name, "force_N")["band_after"]
        narrow = _update(calm["updates"], op.name, "force_N")["band_after"]
        assert wide > narrow, (op.name, wide, narrow)


def test_readings_noisier_than_their_u_predict_a_wider_band_at_the_setpoint(
    server: LiveServer,
) -> None:
    _, _, noisy, honest = _noisy_and_honest(server)
    bands = {
        op.name: (
            _operation(noisy, op.name)["predicted"]["force_N"]["band"],
            _operation(honest, op.name)["predicted"]["force_N"]["band"],
        )
        for op in PLAN.operations
    }
    assert all(wide > narrow for wide, narrow in bands.values()), bands
