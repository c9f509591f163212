"""The shop floor misbehaves, through a real ``rcb serve`` (issue 27's acceptance, 3 and 4).

DESIGN.md, RCB, "The shop floor misbehaves", with the default strategy (``learn``) on the
demonstration plan, over REST on SQLite and PostgreSQL. A virtual machine
(:func:`supervisor.virtual.sampling.sample_machine`) is the truth: each part is made by
:func:`supervisor.virtual.simulate.run_part` at the setpoints in force (GET setpoints) and its
measurements posted with the version they were made with and the rough-od edge's age, as
:func:`supervisor.virtual.scenario.run_scenario` does in process.

3. A gross breach (6000 N on 2000 N) halts the plan; a replan with reset bands resumes.
4. Readings 3x noisier than their reported u leave a wider band than honest ones.

The dropout and the step (1 and 2) are in test_shop_floor_rest.py.
"""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
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
from supervisor.virtual.machine import VirtualMachine
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from live import LiveServer

U_N = 10.0  # the gross breach's force uncertainty [N]


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
        named = "rough-od force_N measured 6000 - 10 = 5990 is past its limit 2000 by 199.5 %"
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
