"""Hypothesis strategies and checks of the property tests (tests/supervisor/test_properties.py,
test_properties_found_bugs.py; test_setpoint_resolution.py draws its plans here too).

Random turning operations are built the way a plan file would give them
(:func:`supervisor.inputs.plan.plan_from_mapping` with an inline tool) and solved; the optimum is
then checked against band edges recomputed here from :class:`models.powerlaw.PowerLawModel` and the
:mod:`models.kinematics` functions, not against the optimiser's own ``predicted`` table.

Limits are drawn as a random factor times the robust value at a random reference point inside
the bounds. A factor of at least ``FEASIBLE`` for every limit makes that point feasible with a
margin well above the solver's tolerance, so ``scenarios(min_factor=FEASIBLE)`` yields only
feasible operations, by construction.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from hypothesis import event, note
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from models import kinematics
from models.powerlaw import PowerLawModel
from models.quantities import MODEL_QUANTITIES
from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan
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
#: infeasible when an exponent is near zero (see test_properties_found_bugs.py).
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
