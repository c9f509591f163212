"""Helpers of the shop-floor REST tests (tests/api/test_shop_floor_rest.py,
test_shop_floor_rest_breach.py): the demonstration plan and its truth's seed, a plan created
over REST, a part report and the answers read back.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from typing import Any

import httpx

from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan

from conftest import DEMO_PLAN, renamed

BODY = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
PLAN = load_plan(DEMO_PLAN)
#: The truth of every test: one virtual machine inside the plan's bands (and its noise seed).
SEED = 0
#: Parts the rough-od edge makes before it is changed (the plan's parts_per_edge).
EDGE_LIFE = 10


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
