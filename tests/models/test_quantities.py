"""The registry of constrained quantities: a new quantity is one entry, an unknown one an error."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from models import quantities
from models.errors import InputError
from models.monomial import Monomial
from models.quantities import (
    DERIVED_QUANTITIES,
    MODEL_QUANTITIES,
    QUANTITIES,
    Quantity,
    UnknownQuantityError,
)
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.formulation import formulate
from supervisor.optimize.optimizer import optimize_plan
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from conftest import FINE, step1_plan

STEP1 = step1_plan(FINE)


@contextmanager
def registered(*extra: Quantity) -> Iterator[None]:
    """A temporary registry: ``extra`` registered inside, the registry restored after."""
    saved = dict(QUANTITIES)
    try:
        for quantity in extra:
            quantities.register(quantity)
        yield
    finally:
        QUANTITIES.clear()
        QUANTITIES.update(saved)


def _cutting_speed_per_m_min(process: str) -> Monomial:
    return Monomial(1.0 / 60.0, {"speed_m_min": 1.0})


def _per_depth(process: str) -> Monomial:
    return Monomial(1.0, {"depth_mm": -1.0})


#: A derived kinematic quantity: the cutting speed in m/s, ``v / 60``.
CUTTING_SPEED = Quantity(
    "cutting_speed_m_s",
    "m/s",
    "max",
    "cutting speed",
    "cutting speed",
    "derived",
    factor=_cutting_speed_per_m_min,
)
#: A derived quantity from the force model: force per mm of depth, ``F / d``.
FORCE_PER_DEPTH = Quantity(
    "force_per_depth_N_mm",
    "N/mm",
    "max",
    "cutting force per mm of depth at the upper force band",
    "force per depth",
    "derived",
    factor=_per_depth,
    based_on="force_N",
)
#: A model quantity with its own power law.
VIBRATION = Quantity("vibration_mm_s", "mm/s", "max", "tool vibration velocity", "vibration")


def _with_limits(**limits: float) -> dict:
    data = {**STEP1, "operations": [dict(STEP1["operations"][0])]}
    data["operations"][0]["limits"] = {**STEP1["operations"][0]["limits"], **limits}
    return data


def test_registry_order_and_views():
    names = list(QUANTITIES)
    assert names[:4] == ["force_N", "roughness_um", "tool_life_mm3", "spindle_current_A"]
    assert list(MODEL_QUANTITIES) == names[:4]
    assert list(DERIVED_QUANTITIES) == ["power_kW", "torque_Nm", "spindle_rpm", "feed_rate_mm_min"]
    assert quantities.machine_fields() == {
        "max_power_kW": "power_kW",
        "max_torque_Nm": "torque_Nm",
        "max_spindle_rpm": "spindle_rpm",
        "max_feed_rate_mm_min": "feed_rate_mm_min",
    }
    assert quantities.limited_by("parts_per_edge").name == "tool_life_mm3"
    assert quantities.quantity("torque_Nm").label == "torque"
    for q in QUANTITIES.values():
        assert q.name and q.unit and q.description and q.label
        assert (q.factor is None) == (q.kind == "model")


def test_unknown_quantity_is_an_error_naming_it():
    with pytest.raises(UnknownQuantityError, match="vibration_mm_s"):
        quantities.quantity("vibration_mm_s")
    with pytest.raises(UnknownQuantityError, match="chatter_Hz"):
        quantities.limited_by("chatter_Hz")
    plan = plan_from_mapping(STEP1)
    op = replace(plan.operations[0], limits={"force_N": 2000, "chatter_Hz": 5.0})
    with pytest.raises(UnknownQuantityError, match="chatter_Hz"):
        formulate(op, plan.tools[op.tool], plan.machine)


def test_register_refuses_what_does_not_fit():
    with registered():
        with pytest.raises(InputError, match="already registered"):
            quantities.register(QUANTITIES["force_N"])
        with pytest.raises(InputError, match="needs a factor"):
            quantities.register(replace(CUTTING_SPEED, factor=None))
        with pytest.raises(InputError, match="not a model quantity"):
            quantities.register(replace(FORCE_PER_DEPTH, based_on="power_kW"))
        with pytest.raises(InputError, match="already bounds another"):
            quantities.register(replace(CUTTING_SPEED, machine_field="max_power_kW"))


def test_a_derived_kinematic_quantity_binds_the_optimum():
    # without it the optimum runs at v = 200 m/min (test_optimizer.test_step1_row_r); 3 m/s
    # is 180 m/min
    with registered(CUTTING_SPEED):
        assert "cutting_speed_m_s" in DERIVED_QUANTITIES
        op = optimize_plan(plan_from_mapping(_with_limits(cutting_speed_m_s=3.0))).operations[0]
        assert "cutting_speed_m_s" in op.binding
        assert_allclose(op.setpoint["speed_m_min"], 180.0, rtol=1e-6)
        assert_allclose(op.predicted["cutting_speed_m_s"].value, 3.0, rtol=1e-6)
        assert op.predicted["cutting_speed_m_s"].band == 0.0
    assert "cutting_speed_m_s" not in QUANTITIES  # restored
    with pytest.raises(InputError, match="cutting_speed_m_s"):
        plan_from_mapping(_with_limits(cutting_speed_m_s=3.0))


def test_a_quantity_derived_from_the_force_band_binds_the_optimum():
    free = optimize_plan(plan_from_mapping(STEP1)).operations[0]
    per_depth = free.predicted["force_N"].upper / free.setpoint["depth_mm"]
    limit = 0.8 * per_depth
    with registered(FORCE_PER_DEPTH):
        plan = plan_from_mapping(_with_limits(force_per_depth_N_mm=limit))
        op = optimize_plan(plan).operations[0]
        assert "force_per_depth_N_mm" in op.binding
        shown = op.predicted["force_per_depth_N_mm"]
        assert_allclose(shown.upper, limit, rtol=1e-6)  # at the upper force band
        force = op.predicted["force_N"]
        assert_allclose(shown.band, force.band / op.setpoint["depth_mm"], rtol=1e-12)
        assert op.mrr_cm3_min < free.mrr_cm3_min
        # the virtual machine's true value follows the same entry
        machine = sample_machine(plan, seed=3)
        outcome = run_part(machine, {"rough-od": op.setpoint}, np.random.default_rng(3))
        values = outcome.true_values["rough-od"]
        assert_allclose(values["force_per_depth_N_mm"], values["force_N"] / op.setpoint["depth_mm"])
        assert values["force_per_depth_N_mm"] <= limit * (1 + 1e-9)


def test_a_model_quantity_binds_the_optimum():
    tool = {
        "name": "VIB-1",
        "process": "turning",
        "models": {
            "force_N": {"K": 1000.0, "dK": 100.0, "exponents": {"depth_mm": 0.8}},
            "vibration_mm_s": {
                "K": 0.5,
                "dK": 0.05,
                "exponents": {"feed_mm_rev": 0.5, "speed_m_min": 0.5},
            },
        },
    }
    data = _with_limits(vibration_mm_s=4.0)
    data["tools"] = [tool]
    data["operations"][0] = {**data["operations"][0], "tool": "VIB-1"}
    data["operations"][0]["limits"] = {"force_N": 5000.0, "vibration_mm_s": 4.0}
    with registered(VIBRATION):
        op = optimize_plan(plan_from_mapping(data)).operations[0]
        assert "vibration_mm_s" in op.binding
        assert_allclose(op.predicted["vibration_mm_s"].upper, 4.0, rtol=1e-6)
        # 0.55 · sqrt(f v) = 4: f v = (4 / 0.55)², the feed and speed trade along it
        f, v = op.setpoint["feed_mm_rev"], op.setpoint["speed_m_min"]
        assert_allclose(f * v, (4.0 / 0.55) ** 2, rtol=1e-6)
        assert math.isclose(op.setpoint["depth_mm"], 3.0)
