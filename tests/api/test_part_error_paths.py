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
        at_idle = {"value": 0.5, "uncertainty": 0.01, "idle_load_V": 0.5}  # converts to 0 N
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
            (  # no cut seen: 0 N is no measurement (a review: ivester shrank its band on it)
                lathe["id"],
                _part("P5", {"name": "rough-od", "measurements": {"spindle_load_V": at_idle}}),
                "operations[0].measurements.spindle_load_V.value",
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


def test_tool_life_comes_through_tool_wear_and_a_stored_one_still_lists(server):
    """A review: ``tool_life_mm3`` given as a measurement was stored (201) and learned from, then
    every page of the plan's parts holding it was a 500 (the stored schema has no such
    quantity); given with ``tool_wear`` too it was a 409 "a concurrent request stored the same
    thing", which an MES retries for ever. It is refused, naming the field and ``tool_wear``."""
    from sqlalchemy import select, update

    from db import tables as t
    from db.engine import make_engine

    life = {"tool_life_mm3": {"value": 1e6, "uncertainty": 1e4}}
    wear = {"flank_wear_mm": {"value": 0.1, "uncertainty": 0.01}, "volume_mm3": 5e5}
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=renamed(DEMO)).json()["id"]
        url = f"/plans/{plan_id}/parts"
        alone = {"name": "rough-od", "measurements": life}
        for n, op in enumerate((alone, {**alone, "tool_wear": wear})):
            r = c.post(url, json=_part(f"L{n}", op), headers={"Idempotency-Key": f"life-{n}"})
            assert r.status_code == 422, r.text
            assert r.json()["field"] == "operations[0].measurements.tool_life_mm3"
            assert "as tool_wear" in r.json()["detail"]
        made = _part("L2", {"name": "rough-od", "measurements": FORCE})
        assert c.post(url, json=made, headers={"Idempotency-Key": "life-2"}).status_code == 201
        engine = make_engine(server.url)  # a part stored before: its force as tool life
        with engine.begin() as connection:
            part = select(t.Part.id).where(t.Part.plan_id == plan_id, t.Part.serial == "L2")
            m = t.Measurement
            connection.execute(update(m).where(m.part_id == part.scalar_subquery()).values(
                quantity="tool_life_mm3"))  # fmt: skip
        engine.dispose()
        listed = c.get(url)
    assert listed.status_code == 200, listed.text
    [item] = listed.json()["items"]
    assert item["operations"][0]["measurements"] == {
        "tool_life_mm3": {**FORCE["force_N"], "raw": None}
    }
