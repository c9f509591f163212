"""A refused part report names its field by the body's path, as the schema's errors do.

Before, an error found after the body's schema check named an operation by its name
(``operations.finish-od.measurements.tool_life_mm3``) and a conversion's context by the name
the conversion reads (``context.spindle_speed_rpm``), where the schema named the same body by
index (``operations[1].measurements``) and the docs promise a dotted path of the body. Through
a real server on each database; nothing is stored on any of them.
"""

from __future__ import annotations

import tomllib

import pytest

from api.services.parts import at_body_path
from models.errors import InputError, InputErrors, ModelDomainError

from conftest import DEMO_PLAN, ROOT, renamed

DEMO = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
LATHE = tomllib.loads((ROOT / "examples" / "virtual_lathe_part.toml").read_text(encoding="utf-8"))
FORCE = {"force_N": {"value": 900.0, "uncertainty": 20.0}}


def _part(serial: str, *operations: dict) -> dict:
    return {"serial": serial, "setpoint_version": 1, "operations": list(operations)}


def test_the_domains_name_becomes_the_bodys_index():
    order = ("rough-od", "finish-od", "rough")  # "rough" is a prefix of "rough-od"
    cases = {
        "operations.finish-od.measurements.power_kW": "operations[1].measurements.power_kW",
        "operations.rough.tool_wear": "operations[2].tool_wear",
        "operations.rough-od": "operations[0].name",  # the operation itself: its name
        "setpoint_version": "setpoint_version",  # not an operation's: as it was
        "operations.nope.measurements": "operations.nope.measurements",  # not in the body
    }
    for domain, body in cases.items():
        moved = at_body_path(ModelDomainError(domain, 7, "why"), order)
        assert (moved.field, moved.value, moved.reason) == (body, 7, "why")
        assert type(moved) is ModelDomainError and str(moved) == f"{body} = 7: why"
    both = InputErrors([InputError("operations.rough.x", 1, "a"), InputError("serial", 2, "b")])
    moved = at_body_path(both, order)
    assert isinstance(moved, InputErrors)
    assert [e.field for e in moved.errors] == ["operations[2].x", "serial"]


def test_a_refused_report_names_the_bodys_path(server):
    with server.client("engineer") as c:
        plan = c.post("/plans", json=renamed(DEMO)).json()
        lathe = c.post("/plans", json=renamed(LATHE)).json()
        too_fast = {"value": 1.0, "uncertainty": 0.02, "spindle_speed_rpm": 9000.0}
        cases = [
            (  # the finish insert models no tool life: named where the body gives it
                plan["id"],
                _part(
                    "P1",
                    {"name": "rough-od", "measurements": FORCE},
                    {"name": "finish-od", "measurements": {"tool_life_mm3": FORCE["force_N"]}},
                ),
                "operations[1].measurements.tool_life_mm3",
            ),
            *(  # an operation the plan does not have, or one listed twice: the second's name
                (
                    plan["id"],
                    _part(
                        serial,
                        {"name": "rough-od", "measurements": FORCE},
                        {"name": second, "measurements": FORCE},
                    ),
                    "operations[1].name",
                )
                for serial, second in (("P2", "nope"), ("P4", "rough-od"))
            ),  # fmt: skip
            (  # a speed outside the idle-load table: the reading's own field that gave it
                lathe["id"],
                _part("P3", {"name": "rough-od", "measurements": {"spindle_load_V": too_fast}}),
                "operations[0].measurements.spindle_load_V.spindle_speed_rpm",
            ),
        ]
        for n, (plan_id, body, field) in enumerate(cases):
            url = f"/plans/{plan_id}/parts"
            r = c.post(url, json=body, headers={"Idempotency-Key": f"path-{n}"})
            assert r.status_code == 422, r.text
            problem = r.json()
            assert problem["field"] == field, problem
            assert problem["detail"].startswith(field), problem
            assert [e["field"] for e in problem["errors"]] == [field]
        for plan_id in (plan["id"], lathe["id"]):
            assert c.get(f"/plans/{plan_id}/parts").json()["items"] == []


@pytest.mark.parametrize("path", [None, "operations[0].measurements.spindle_load_V"])
def test_a_conversion_names_a_context_entry_under_its_readings_path(path):
    from models.sensors import to_force
    from supervisor.inputs.plan import plan_from_mapping

    calibration = plan_from_mapping(LATHE).machine.calibrations["spindle_load"]
    context = {"spindle_speed_rpm": 9000.0, "workpiece_diameter_mm": 60.0}
    with pytest.raises(InputError) as err:
        to_force(calibration, "spindle_load_V", 1.0, 0.02, context, path=path)
    named = "context.spindle_speed_rpm" if path is None else f"{path}.spindle_speed_rpm"
    assert err.value.field == named
