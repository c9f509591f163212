"""The shop floor misbehaves, through a real ``rcb serve`` (issue 27's acceptance, 1 and 2).

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

The gross breach and the noisy readings (3 and 4 of the acceptance) are in
test_shop_floor_rest_breach.py; the helpers in tests/shop_floor_support.py.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
from typing import Any

import httpx
import numpy as np
import pytest
from shop_floor_support import (
    EDGE_LIFE,
    PLAN,
    SEED,
    _create,
    _made_at,
    _operation,
    _post,
    _report,
    _setpoints,
    _update,
)

from supervisor.inputs.part_report import Measurement
from supervisor.virtual.machine import TrueProcess, VirtualMachine
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from conftest import ROOT
from live import RCB, LiveServer

#: The measured quantities whose truth the step raises (every "max" model quantity).
STEPPED = ("force_N", "roughness_um", "spindle_current_A")
STEP = 1.12


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
