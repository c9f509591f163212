"""Property tests (Hypothesis) of the power-law models and the robust optimiser.

Random turning operations are built the way a plan file would give them
(:func:`supervisor.inputs.plan.plan_from_mapping` with an inline tool) and solved; the optimum is
then checked against band edges recomputed here from :class:`models.powerlaw.PowerLawModel` and the
:mod:`models.kinematics` functions, not against the optimiser's own ``predicted`` table.

Limits are drawn as a random factor times the robust value at a random reference point inside
the bounds. A factor of at least ``FEASIBLE`` for every limit makes that point feasible with a
margin well above the solver's tolerance, so ``scenarios(min_factor=FEASIBLE)`` yields only
feasible operations, by construction.

The last section holds deterministic tests of the bugs these properties found.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given, note, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from models import kinematics
from models.powerlaw import PowerLawModel
from models.quantities import MODEL_QUANTITIES
from supervisor.errors import InfeasibleError, PlanError
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_operation, optimize_plan
from supervisor.optimize.result import OperationResult

from conftest import FINE

PARAMS = kinematics.PARAMETERS["turning"]
TOOL = "PROPERTY-INSERT"
#: A re-computed band edge may pass its limit by this fraction (solver tolerance).
LIMIT_RTOL = 1e-6
#: A setpoint may pass its bound by this fraction (``exp(log(x))`` rounding).
BOUND_RTOL = 1e-9
#: Two optima's removal rates are compared to this fraction, on well-conditioned problems.
MRR_RTOL = 1e-7
#: HiGHS's primal feasibility tolerance: a row ``a·ln(x) <= b`` may be passed by this much.
SOLVER_FEAS_TOL = 1e-7
#: Margin that makes a point feasible beyond doubt: 100 ppm, 1000x the solver's tolerance. A
#: limit exactly at (or a few ppm above) a point's value is a knife edge that HiGHS may call
#: infeasible when an exponent is near zero (see the regression tests at the end).
MARGIN = 1e-4
#: Least limit factor that makes the reference point feasible.
FEASIBLE = 1 + MARGIN
#: Flank-wear criterion VB when the operation gives none (ISO 3685).
ISO_3685_VB_MM = 0.3

#: Machine field of each derived quantity.
MACHINE_FIELDS = {
    "power_kW": "max_power_kW",
    "spindle_rpm": "max_spindle_rpm",
    "torque_Nm": "max_torque_Nm",
    "feed_rate_mm_min": "max_feed_rate_mm_min",
}
#: Exponent ranges of force-like models (force, roughness, spindle current).
CUTTING_EXPONENTS = {"depth_mm": (0.0, 1.2), "feed_mm_rev": (0.3, 1.5), "speed_m_min": (-0.5, 0.5)}
#: Exponent ranges of the tool-life model (Taylor-like: life falls with speed, rises with VB).
TOOL_LIFE_EXPONENTS = {
    "depth_mm": (0.0, 0.6),
    "feed_mm_rev": (-0.5, 0.5),
    "speed_m_min": (-3.0, -0.3),
    "flank_wear_mm": (0.5, 2.0),
}
#: Coefficient range of each model quantity.
K_RANGES = {
    "force_N": (100.0, 5000.0),
    "roughness_um": (5.0, 100.0),
    "spindle_current_A": (1.0, 50.0),
    "tool_life_mm3": (1e7, 1e10),
}
#: (smallest low, largest low, largest high/low) of each bound.
BOUND_RANGES = {
    "depth_mm": (0.1, 3.0, 5.0),
    "feed_mm_rev": (0.03, 0.4, 5.0),
    "speed_m_min": (30.0, 250.0, 4.0),
}


# --------------------------------------------------------------------------- strategies


def log_uniform(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Floats spread evenly in ln between ``lo`` and ``hi``."""
    return st.floats(math.log(lo), math.log(hi)).map(math.exp)


@st.composite
def model_table(
    draw: st.DrawFn,
    quantity: str,
    exponent_ranges: Mapping[str, tuple[float, float]],
    max_dK_over_K: float = 0.95,
) -> dict[str, Any]:
    """One ``{K, dK, exponents}`` table as in a plan file, ``0 <= dK < K``."""
    K = draw(log_uniform(*K_RANGES[quantity]))
    dK = K * draw(st.floats(0.0, max_dK_over_K))
    exponents = {name: draw(st.floats(lo, hi)) for name, (lo, hi) in exponent_ranges.items()}
    return {"K": K, "dK": dK, "exponents": exponents}


@st.composite
def bound_pair(draw: st.DrawFn, smallest: float, largest: float, ratio: float) -> list[float]:
    """``[low, high]`` with ``low < high``."""
    low = draw(log_uniform(smallest, largest))
    return [low, low * draw(st.floats(1.01, ratio))]


def turning_bounds() -> st.SearchStrategy[dict[str, list[float]]]:
    """Bounds of depth, feed and speed."""
    return st.fixed_dictionaries({p: bound_pair(*BOUND_RANGES[p]) for p in PARAMS})


def setpoint_uncertainties() -> st.SearchStrategy[dict[str, float]]:
    """Relative setpoint uncertainties of some (or none) of the parameters."""
    return st.fixed_dictionaries({}, optional={p: st.floats(0.0, 0.05) for p in PARAMS})


@dataclass(frozen=True)
class Scenario:
    """A random turning operation, as plan data and as the facts the checks need."""

    data: dict[str, Any]
    models: dict[str, dict[str, Any]]
    context: dict[str, float]
    rel: dict[str, float]
    bounds: dict[str, list[float]]
    volume: float
    reference: dict[str, float]
    #: Effective limits: quantity -> (sense, limit in the quantity's unit).
    limits: dict[str, tuple[str, float]]
    feasible_at_reference: bool

    @property
    def name(self) -> str:
        return str(self.data["operations"][0]["name"])

    @property
    def op_limits(self) -> dict[str, float]:
        return dict(self.data["operations"][0]["limits"])


@st.composite
def scenarios(
    draw: st.DrawFn,
    *,
    min_factor: float = 0.5,
    max_factor: float = 8.0,
    tool_life: bool | None = None,
) -> Scenario:
    """A turning operation whose limits are random multiples of the robust values at a point.

    ``tool_life``: ``True`` always gives the tool a tool-life model and the operation a
    ``parts_per_edge`` limit, ``None`` sometimes, ``False`` never.
    """
    models = {"force_N": draw(model_table("force_N", CUTTING_EXPONENTS))}
    if draw(st.booleans()):
        ranges = dict(CUTTING_EXPONENTS)
        if draw(st.booleans()):
            ranges["workpiece_diameter_mm"] = (-0.3, 0.3)
        models["roughness_um"] = draw(model_table("roughness_um", ranges))
    if draw(st.booleans()):
        models["spindle_current_A"] = draw(model_table("spindle_current_A", CUTTING_EXPONENTS))
    with_life = draw(st.booleans()) if tool_life is None else tool_life
    if with_life:
        models["tool_life_mm3"] = draw(model_table("tool_life_mm3", TOOL_LIFE_EXPONENTS, 0.8))

    bounds = draw(turning_bounds())
    diameter = draw(log_uniform(20.0, 200.0))
    wear = draw(st.none() | st.floats(0.1, 0.6))
    context = {
        "workpiece_diameter_mm": diameter,
        "flank_wear_mm": ISO_3685_VB_MM if wear is None else wear,
    }
    rel = draw(setpoint_uncertainties())
    volume = draw(log_uniform(1e3, 1e6))
    reference = {p: lo * (hi / lo) ** draw(st.floats(0.0, 1.0)) for p, (lo, hi) in bounds.items()}
    at_reference = robust_edges(models, reference, context, rel)

    factors: list[float] = []

    def factor() -> float:
        f = draw(log_uniform(min_factor, max_factor))
        factors.append(f)
        return f

    op_limits: dict[str, float] = {"force_N": at_reference["force_N"] * factor()}
    limits: dict[str, tuple[str, float]] = {"force_N": ("max", op_limits["force_N"])}
    for quantity in ("roughness_um", "spindle_current_A"):
        if quantity in models and draw(st.booleans()):
            op_limits[quantity] = at_reference[quantity] * factor()
            limits[quantity] = ("max", op_limits[quantity])
    if with_life and (tool_life or draw(st.booleans())):
        op_limits["parts_per_edge"] = at_reference["tool_life_mm3"] / (volume * factor())
        limits["tool_life_mm3"] = ("min", op_limits["parts_per_edge"] * volume)
    machine: dict[str, Any] = {"name": "property-lathe", "resolution": FINE}
    for quantity, machine_field in MACHINE_FIELDS.items():
        where = draw(st.sampled_from(["nowhere", "machine", "operation", "both"]))
        given = []
        if where in ("machine", "both"):
            machine[machine_field] = at_reference[quantity] * factor()
            given.append(machine[machine_field])
        if where in ("operation", "both"):
            op_limits[quantity] = at_reference[quantity] * factor()
            given.append(op_limits[quantity])
        if given:
            limits[quantity] = ("max", min(given))

    operation: dict[str, Any] = {
        "name": f"op-{draw(st.integers(1, 99))}",
        "tool": TOOL,
        "workpiece_diameter_mm": diameter,
        "volume_mm3": volume,
        "limits": op_limits,
        "bounds": bounds,
        "setpoint_rel_uncertainty": rel,
    }
    if wear is not None:
        operation["allowable_flank_wear_mm"] = wear
    data = {
        "name": "property-plan",
        "machine": machine,
        "tools": [{"name": TOOL, "process": "turning", "models": models}],
        "operations": [operation],
    }
    return Scenario(
        data=data,
        models=models,
        context=context,
        rel=rel,
        bounds=bounds,
        volume=volume,
        reference=reference,
        limits=limits,
        feasible_at_reference=min(factors) >= FEASIBLE,
    )


@st.composite
def models_and_points(draw: st.DrawFn) -> tuple[PowerLawModel, dict[str, float], dict[str, float]]:
    """Any power-law model, a positive point and non-negative relative uncertainties."""
    names = ("depth_mm", "feed_mm_rev", "speed_m_min", "workpiece_diameter_mm", "flank_wear_mm")
    used = draw(st.lists(st.sampled_from(names), unique=True, max_size=len(names)))
    K = draw(log_uniform(1e-3, 1e9))
    model = PowerLawModel(
        quantity=draw(st.sampled_from(list(MODEL_QUANTITIES))),
        K=K,
        dK=K * draw(st.floats(0.0, 3.0)),
        exponents={n: draw(st.floats(-3.0, 3.0)) for n in used},
    )
    point = {n: draw(log_uniform(1e-2, 1e3)) for n in names}
    rel = draw(st.dictionaries(st.sampled_from(names), st.floats(0.0, 0.5)))
    return model, point, rel


# --------------------------------------------------------------------------- helpers


def robust_edges(
    models: Mapping[str, Mapping[str, Any]],
    setpoint: Mapping[str, float],
    context: Mapping[str, float],
    rel: Mapping[str, float],
) -> dict[str, float]:
    """The constrained band edge of every quantity at ``setpoint``, computed from scratch.

    Maxima at the upper edge, tool life at the lower edge; power and torque from the upper
    force edge; spindle speed and feed rate exact.
    """
    point = {**setpoint, **context}
    edges: dict[str, float] = {}
    for quantity, table in models.items():
        model = PowerLawModel(quantity, table["K"], table["dK"], table["exponents"])
        prediction = model.predict(point, rel)
        edges[quantity] = prediction.lower if quantity == "tool_life_mm3" else prediction.upper
    speed = setpoint["speed_m_min"]
    diameter = context["workpiece_diameter_mm"]
    rpm = kinematics.turning_spindle_rpm(speed, diameter)
    edges["power_kW"] = kinematics.cutting_power_kW(edges["force_N"], speed)
    edges["torque_Nm"] = kinematics.spindle_torque_Nm(edges["force_N"], diameter)
    edges["spindle_rpm"] = rpm
    edges["feed_rate_mm_min"] = setpoint["feed_mm_rev"] * rpm
    return edges


def mrr_at(setpoint: Mapping[str, float]) -> float:
    return kinematics.turning_mrr_cm3_min(
        setpoint["depth_mm"], setpoint["feed_mm_rev"], setpoint["speed_m_min"]
    )


def mrr_rtol(sc: Scenario) -> float:
    """How closely the removal rates of two optima of ``sc`` can be compared.

    The solver holds each ln-space row to :data:`SOLVER_FEAS_TOL`, so along a row whose
    exponent of a parameter is ``e`` that parameter (and the MRR with it) is only determined to
    ``SOLVER_FEAS_TOL / |e|`` in ln. A near-zero exponent makes the optimum ill-conditioned:
    e.g. a depth exponent of 1e-6 with the force limit binding lets the depth drift 0.35 %.
    """
    exponents = [
        abs(e)
        for table in sc.models.values()
        for name, e in table["exponents"].items()
        if name in PARAMS and e != 0
    ]
    smallest = min([1.0, *exponents])
    return MRR_RTOL + len(PARAMS) * SOLVER_FEAS_TOL / smallest


def solve(data: Mapping[str, Any]) -> OperationResult:
    """Build the plan from its mapping and solve its single operation."""
    return optimize_plan(plan_from_mapping(data)).operations[0]


def check_optimum(result: OperationResult, sc: Scenario) -> None:
    """Every limit holds at the band edge and every parameter within its bounds."""
    setpoint = result.setpoint
    note(f"setpoint: {dict(setpoint)}")
    for param, (lo, hi) in sc.bounds.items():
        assert lo * (1 - BOUND_RTOL) <= setpoint[param] <= hi * (1 + BOUND_RTOL), param
    edges = robust_edges(sc.models, setpoint, sc.context, sc.rel)
    for quantity, (sense, limit) in sc.limits.items():
        if sense == "max":
            assert edges[quantity] <= limit * (1 + LIMIT_RTOL), (quantity, edges[quantity], limit)
        else:
            assert edges[quantity] >= limit * (1 - LIMIT_RTOL), (quantity, edges[quantity], limit)
    assert_allclose(result.mrr_cm3_min, mrr_at(setpoint), rtol=1e-12)


def check_infeasible(err: InfeasibleError, sc: Scenario) -> None:
    """The error names the operation and what holds it; its remedy suffices."""
    assert err.conflicts or err.against
    assert err.operation == sc.name
    assert repr(sc.name) in str(err)
    event(f"{len(err.conflicts)} conflict(s)")
    for conflict in err.conflicts:
        if conflict.sense == "max":
            assert conflict.required >= conflict.limit
        else:
            assert conflict.required <= conflict.limit
    relaxed = copy.deepcopy(sc.data)
    op_limits = relaxed["operations"][0]["limits"]
    machine = relaxed["machine"]
    # Give every conflicting limit what the diagnosis says it needs, and every limit MARGIN (a
    # violation within the solver's tolerance need not be named); then it solves.
    for key, value in op_limits.items():
        op_limits[key] = value * (1 - MARGIN) if key == "parts_per_edge" else value * (1 + MARGIN)
    for key in MACHINE_FIELDS.values():
        if key in machine:
            machine[key] *= 1 + MARGIN
    for conflict in err.conflicts:
        if conflict.sense == "min":
            assert conflict.name == "parts_per_edge"
            if conflict.required <= 0:  # no tool life is guaranteed at all: nothing to move
                return
            op_limits[conflict.name] = conflict.required * (1 - MARGIN)
            continue
        # A limit is named as given: a derived one as the machine's or the operation's.
        quantity = conflict.name.removeprefix("machine.max_")
        assert conflict.name in op_limits or MACHINE_FIELDS.get(quantity) in machine
        if quantity in op_limits:
            op_limits[quantity] = conflict.required * (1 + MARGIN)
        if MACHINE_FIELDS.get(quantity) in machine:
            machine[MACHINE_FIELDS[quantity]] = conflict.required * (1 + MARGIN)
    solve(relaxed)


# --------------------------------------------------------------------------- properties


@settings(max_examples=100, deadline=None)
@given(scenarios())
def test_robust_optimum_respects_every_limit_at_the_band_edge_and_every_bound(sc: Scenario):
    try:
        result = solve(sc.data)
    except InfeasibleError as err:
        event("infeasible")
        assert not sc.feasible_at_reference, f"the reference point {sc.reference} is feasible"
        check_infeasible(err, sc)
        return
    event("feasible")
    check_optimum(result, sc)


@settings(max_examples=80, deadline=None)
@given(scenarios(min_factor=FEASIBLE))
def test_feasible_operation_solves_at_least_as_fast_as_the_reference_point(sc: Scenario):
    plan = plan_from_mapping(sc.data)
    operation = plan.operations[0]
    result = optimize_operation(operation, plan.tools[operation.tool], plan.machine)
    check_optimum(result, sc)
    assert result.mrr_cm3_min >= mrr_at(sc.reference) * (1 - mrr_rtol(sc))


@settings(max_examples=60, deadline=None)
@given(scenarios(min_factor=FEASIBLE), st.data())
def test_loosening_a_limit_never_lowers_the_mrr(sc: Scenario, data: st.DataObject):
    before = solve(sc.data)
    keys = [("operations", q) for q in sc.op_limits]
    keys += [("machine", k) for k in MACHINE_FIELDS.values() if k in sc.data["machine"]]
    where, key = data.draw(st.sampled_from(keys), label="limit")
    factor = data.draw(st.floats(1.0, 10.0), label="factor")
    loosened = copy.deepcopy(sc.data)
    table = loosened["machine"] if where == "machine" else loosened["operations"][0]["limits"]
    # parts_per_edge is a minimum: loosening it means asking for fewer parts.
    table[key] = table[key] / factor if key == "parts_per_edge" else table[key] * factor
    after = solve(loosened)
    assert after.mrr_cm3_min >= before.mrr_cm3_min * (1 - mrr_rtol(sc))


@settings(max_examples=60, deadline=None)
@given(scenarios(min_factor=FEASIBLE), st.sampled_from(PARAMS), st.floats(0.0, 1.0))
def test_tightening_an_upper_bound_never_raises_the_mrr(sc: Scenario, param: str, t: float):
    before = solve(sc.data)
    tightened = copy.deepcopy(sc.data)
    lo, hi = tightened["operations"][0]["bounds"][param]
    new_hi = min(hi, lo * (hi / lo) ** t)
    tightened["operations"][0]["bounds"][param] = [lo, new_hi]
    try:
        after = solve(tightened)
    except InfeasibleError:
        event("infeasible after tightening")
        return
    except PlanError as err:  # t = 0: [lo, lo], no point of the (fine) grid in it
        event("no grid point left in the bounds")
        assert err.field == f"operations[0].bounds.{param}"
        return
    event("feasible after tightening")
    assert after.setpoint[param] <= new_hi * (1 + BOUND_RTOL)
    assert after.mrr_cm3_min <= before.mrr_cm3_min * (1 + mrr_rtol(sc))


@settings(max_examples=80, deadline=None)
@given(scenarios(tool_life=True))
def test_tool_life_lower_band_edge_covers_the_parts_per_edge(sc: Scenario):
    parts = sc.op_limits["parts_per_edge"]
    try:
        result = solve(sc.data)
    except InfeasibleError as err:
        event("infeasible")
        check_infeasible(err, sc)
        return
    event("feasible")
    table = sc.models["tool_life_mm3"]
    model = PowerLawModel("tool_life_mm3", table["K"], table["dK"], table["exponents"])
    # The life is read at the allowable flank wear (ISO 3685 VB = 0.3 mm when none is given).
    point = {**result.setpoint, **sc.context}
    life = model.predict(point, sc.rel)
    assert life.lower >= parts * sc.volume * (1 - LIMIT_RTOL)
    assert_allclose(result.predicted["tool_life_mm3"].lower, life.lower, rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    scenarios(tool_life=True),
    st.floats(1.0, 3.0),
)
def test_tool_life_band_wider_than_K_is_a_parts_per_edge_conflict(sc: Scenario, ratio: float):
    # dK >= K: the lower edge of tool life is <= 0, so no parts_per_edge can be met. The
    # conflict names the limit as given, like the conflicts of the elastic diagnosis do.
    data = copy.deepcopy(sc.data)
    life = data["tools"][0]["models"]["tool_life_mm3"]
    life["dK"] = life["K"] * ratio
    with pytest.raises(InfeasibleError) as info:
        solve(data)
    err = info.value
    assert err.operation == sc.name and repr(sc.name) in str(err)
    (conflict,) = err.conflicts
    assert conflict.name == "parts_per_edge"
    assert conflict.sense == "min"
    assert conflict.limit == sc.op_limits["parts_per_edge"]
    assert conflict.required <= 0.0


@settings(max_examples=100, deadline=None)
@given(models_and_points(), st.floats(0.0, 1e3), st.floats(0.0, 0.5), st.data())
def test_robust_band_brackets_the_nominal_and_grows_with_uncertainty(
    case: tuple[PowerLawModel, dict[str, float], dict[str, float]],
    extra_dK_over_K: float,
    extra_rel: float,
    data: st.DataObject,
):
    model, point, rel = case
    prediction = model.predict(point, rel)
    assert prediction.band >= 0
    assert prediction.lower <= prediction.value <= prediction.upper

    # First-order GUM law with the exponent inside the square, and the monomial itself.
    expected_rel = math.sqrt(
        (model.dK / model.K) ** 2
        + sum((model.exponents.get(n, 0.0) * r) ** 2 for n, r in rel.items())
    )
    logs = sum(e * math.log(point[n]) for n, e in model.exponents.items())
    assert_allclose(prediction.value, model.K * math.exp(logs), rtol=1e-9)
    assert_allclose(prediction.band, prediction.value * expected_rel, rtol=1e-12)

    wider_K = replace(model, dK=model.dK + extra_dK_over_K * model.K)
    assert wider_K.predict(point, rel).band >= prediction.band
    name = data.draw(st.sampled_from(sorted(point)), label="uncertain input")
    wider_rel = {**rel, name: rel.get(name, 0.0) + extra_rel}
    assert model.predict(point, wider_rel).band >= prediction.band


@settings(max_examples=100, deadline=None)
@given(models_and_points(), st.data())
def test_band_is_the_first_order_change_of_the_monomial(
    case: tuple[PowerLawModel, dict[str, float], dict[str, float]], data: st.DataObject
):
    model, point, _ = case
    exponents = {n: e for n, e in model.exponents.items() if abs(e) >= 0.05}
    if not exponents:
        exponents = {"feed_mm_rev": 1.0}
    model = replace(model, dK=0.0, exponents=exponents)
    name = data.draw(st.sampled_from(sorted(exponents)), label="perturbed input")
    r = 1e-6
    nominal = model.predict(point, {name: r})
    moved = model.predict({**point, name: point[name] * (1 + r)}).value
    change = abs(moved - nominal.value) / nominal.value
    assert_allclose(change, nominal.band / nominal.value, rtol=1e-4)


@settings(max_examples=100, deadline=None)
@given(
    model_table("force_N", {**CUTTING_EXPONENTS, "feed_mm_rev": (0.05, 1.5)}),
    st.fixed_dictionaries({p: log_uniform(*BOUND_RANGES[p][:2]) for p in PARAMS}),
    st.floats(1.001, 10.0),
    setpoint_uncertainties(),
)
def test_force_rises_with_feed_when_its_exponent_is_positive(
    table: dict[str, Any], point: dict[str, float], ratio: float, rel: dict[str, float]
):
    model = PowerLawModel("force_N", table["K"], table["dK"], table["exponents"])
    low = model.predict(point, rel)
    high = model.predict({**point, "feed_mm_rev": point["feed_mm_rev"] * ratio}, rel)
    assert high.value > low.value
    assert high.upper > low.upper
    assert high.lower > low.lower
    assert_allclose(high.value / low.value, ratio ** table["exponents"]["feed_mm_rev"], rtol=1e-9)


@settings(max_examples=60, deadline=None)
@given(
    st.fixed_dictionaries({p: log_uniform(*BOUND_RANGES[p][:2]) for p in PARAMS}),
    log_uniform(1.0, 500.0),
    log_uniform(10.0, 1e4),
)
def test_kinematics_match_the_handbook_formulas(
    setpoint: dict[str, float], diameter: float, force: float
):
    d, f, v = (setpoint[p] for p in PARAMS)
    assert_allclose(kinematics.turning_spindle_rpm(v, diameter), 1000 * v / (np.pi * diameter))
    assert_allclose(kinematics.turning_mrr_cm3_min(d, f, v), d * f * v)
    assert_allclose(kinematics.cutting_power_kW(force, v), force * v / 60000)
    assert_allclose(kinematics.spindle_torque_Nm(force, diameter), force * diameter / 2000)


# --------------------------------------------------------------------------- found bugs


def two_tool_plan(operations: list[str]) -> dict[str, Any]:
    """Operations ``a`` (feasible) and ``b`` (infeasible), with 6 rows each: one cached program.

    Found by the properties above; tool B's depth exponent of 1e-7 is what makes the solver's
    warm start from ``a``'s optimum fail.
    """
    tools = [
        {
            "name": "A",
            "process": "turning",
            "models": {
                "force_N": {"K": 3000.0, "exponents": {"feed_mm_rev": 1.0}},
                "spindle_current_A": {"K": 1.0, "exponents": {"feed_mm_rev": 1.0}},
                "tool_life_mm3": {"K": 2e7},
            },
        },
        {
            "name": "B",
            "process": "turning",
            "models": {
                "force_N": {
                    "K": 3000.0,
                    "exponents": {"depth_mm": 1e-7, "feed_mm_rev": 0.69, "speed_m_min": 0.04},
                },
                "roughness_um": {"K": 10.0, "exponents": {"depth_mm": 0.7, "feed_mm_rev": 1.49}},
                "tool_life_mm3": {"K": 1e9},
            },
        },
    ]
    ops = {
        "a": {
            "name": "a",
            "tool": "A",
            "workpiece_diameter_mm": 110.0,
            "volume_mm3": 90000.0,
            "limits": {
                "force_N": 300.0,
                "spindle_current_A": 0.2,
                "parts_per_edge": 0.06,
                "power_kW": 0.5,
                "spindle_rpm": 200.0,
                "feed_rate_mm_min": 80.0,
            },
            "bounds": {
                "depth_mm": [1.0, 3.0],
                "feed_mm_rev": [0.04, 0.2],
                "speed_m_min": [66.0, 100.0],
            },
        },
        "b": {
            "name": "b",
            "tool": "B",
            "workpiece_diameter_mm": 200.0,
            "volume_mm3": 50000.0,
            "limits": {
                "force_N": 700.0,
                "roughness_um": 0.8,
                "parts_per_edge": 8.0,
                "power_kW": 20.0,
                "spindle_rpm": 3000.0,
                "torque_Nm": 100.0,
            },
            "bounds": {
                "depth_mm": [1.0, 4.0],
                "feed_mm_rev": [0.12, 0.3],
                "speed_m_min": [80.0, 300.0],
            },
        },
    }
    return {
        "name": "two-tools",
        "machine": {"name": "lathe", "resolution": FINE},
        "tools": tools,
        "operations": [ops[name] for name in operations],
    }


def test_an_infeasible_operation_stays_infeasible_after_a_feasible_one():
    # Failed at e73a820: the cached program warm-started HiGHS with a's optimum, b then got
    # status kUnknown and cvxpy's ValueError("Cannot unpack invalid solution") escaped. At
    # 3aebb94 (presolve off) b alone ended kUnknown and raised the same ValueError.
    with pytest.raises(InfeasibleError) as alone:
        optimize_plan(plan_from_mapping(two_tool_plan(["b"])))
    assert alone.value.operation == "b"
    with pytest.raises(InfeasibleError) as after:
        optimize_plan(plan_from_mapping(two_tool_plan(["a", "b"])))
    assert after.value.operation == "b"


def test_a_limit_slightly_too_tight_is_named_as_the_conflict():
    # Failed at e73a820: the diagnosis named a row only beyond BINDING_TOL = 1e-6 in ln while
    # HiGHS calls the program infeasible beyond about 1e-7, so a limit 0.5 ppm too tight gave
    # an InfeasibleError with no conflict and force_N listed as "held by".
    # The force is 2000·d·f, least at the lower corner: 200 N; the limit is 0.5 ppm below it.
    limit = 200.0 * (1 - 5e-7)
    data = {
        "name": "tight",
        "machine": {"name": "lathe", "resolution": FINE},
        "tools": [
            {
                "name": TOOL,
                "process": "turning",
                "models": {
                    "force_N": {"K": 2000.0, "exponents": {"depth_mm": 1, "feed_mm_rev": 1}}
                },
            }
        ],
        "operations": [
            {
                "name": "rough",
                "tool": TOOL,
                "workpiece_diameter_mm": 50.0,
                "volume_mm3": 1000.0,
                "limits": {"force_N": limit},
                "bounds": {
                    "depth_mm": [1.0, 2.0],
                    "feed_mm_rev": [0.1, 0.2],
                    "speed_m_min": [100.0, 200.0],
                },
            }
        ],
    }
    with pytest.raises(InfeasibleError) as info:
        solve(data)
    assert [c.name for c in info.value.conflicts] == ["force_N"]
    assert "force_N <=" in str(info.value)


def test_a_power_limit_just_above_its_least_value_is_met():
    # Failed at e73a820 and dd5f149: HiGHS presolve called this feasible program infeasible,
    # and the diagnosis, finding no slack, named a conflict whose required == limit.
    # Power F·v/60000 with F = 148.41316·d^5.1e-6·f^0.375 is least at the lower corner of the
    # bounds, 0.0928193789 kW: the lower corner meets the limit with 2 ppm to spare.
    limit = 0.092819564
    force = {"K": 148.41316, "exponents": {"depth_mm": 5.1e-6, "feed_mm_rev": 0.375}}
    bounds = {
        "depth_mm": [1.0, 1.5],
        "feed_mm_rev": [0.36787944, 0.7],
        "speed_m_min": [54.59815, 100],
    }
    models = {"force_N": {**force, "dK": 0.0}}
    context = {"workpiece_diameter_mm": 20.0, "flank_wear_mm": ISO_3685_VB_MM}
    lower_corner = {p: lo for p, (lo, _) in bounds.items()}
    assert robust_edges(models, lower_corner, context, {})["power_kW"] < limit * (1 - 1e-6)
    data = {
        "name": "thin",
        "machine": {"name": "lathe", "max_power_kW": limit, "resolution": FINE},
        "tools": [{"name": TOOL, "process": "turning", "models": {"force_N": force}}],
        "operations": [
            {
                "name": "finish",
                "tool": TOOL,
                "workpiece_diameter_mm": 20.0,
                "volume_mm3": 1000.0,
                "bounds": bounds,
            }
        ],
    }
    power = robust_edges(models, solve(data).setpoint, context, {})["power_kW"]
    assert power <= limit * (1 + LIMIT_RTOL)
