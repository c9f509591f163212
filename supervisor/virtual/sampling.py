r"""Drawing a virtual machine's true processes inside the plan's model bands, and the oracle.

The truth of every model is ``K (1 + δ) Π x_i^(e_i + ε_i)``, kept inside the band ``±ΔK`` of
the nominal model over the operation's bounds (Ivester & Heigel Eqs. 5, 6, 8 and Table 5:
the measurements lay "consistently within the ranges predicted by their respective models");
:func:`oracle_tools` hands the truth to the optimiser, the fastest any controller could run.

:func:`sample_machine`: for every operation (in plan order, each with its own sub-stream of
``numpy.random.default_rng(seed)``) and every model of its tool with ``dK > 0`` (in
quantity-name order), the true model is

.. math:: Y_\mathrm{true} = K (1 + \delta) \prod_i x_i^{e_i + \varepsilon_i},
          \quad \varepsilon_i \sim N(0, (s_e e_i)^2),
          \quad \delta \sim N(0, (s\,\Delta K / K)^2)
          \text{ truncated so that }
          1 - \frac{\Delta K}{K} \le (1 + \delta) \prod_i x_i^{\varepsilon_i}
          \le 1 + \frac{\Delta K}{K}

at every corner of the operation's bounds box (context inputs such as ``flank_wear_mm`` at the
operation's value). The ratio true/nominal is log-linear in ``ln x``, so its extremes over the
box are at the corners and the truth stays inside the band everywhere in the box (outside the
bounds, e.g. a catalogue setpoint beyond them, it may leave the band). Where even ``δ = 0``
leaves a corner outside, ``ε`` is shrunk toward 0 until it fits. Models with ``dK = 0`` stay
exact.

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST): Eqs. 5, 6 and 8, "Cutting Force
   Models" (ΔK is "the range of K that encompasses all of the points in the data set").
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping

import numpy as np

from models import quantities
from models.errors import InputError
from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.inputs.plan import Operation, Plan
from supervisor.virtual.machine import DEFAULT_UNCERTAINTY, TrueProcess, VirtualMachine

#: The truth is kept this far (relative, in ln) inside the band edge, against round-off.
_BAND_MARGIN = 1e-12


def sample_machine(
    plan: Plan,
    seed: int,
    *,
    spread: float = 1 / 3,
    exponent_spread: float = 0.05,
    uncertainty: Mapping[str, float] | None = None,
    wear_drift_per_edge_life: float = 0.0,
) -> VirtualMachine:
    """A virtual machine whose true processes are drawn inside the plan's model bands.

    The model of the draw is in the module docstring.

    Parameters
    ----------
    plan : Plan
        The plan; nominal models are its tools.
    seed : int
        Seed of the draw; the same seed gives the same machine.
    spread : float
        Standard deviation of ``δ`` as a fraction of the band ``ΔK/K`` [-]. The default 1/3
        reads the band as 3σ: the paper's bands encompass all of a few dozen data points
        (Ivester & Heigel, "Cutting Force Models"), and the largest ``|z|`` of 30-100 normal
        draws is 2.3-2.7 on average, so a band is about 2.5-3 standard deviations of the
        process about the model. The truncation keeps every truth inside its band, as the
        paper's measurements were.
    exponent_spread : float
        Standard deviation of ``ε_i`` relative to ``|e_i|`` [-].
    uncertainty : Mapping[str, float], optional
        Expanded measurement uncertainties by quantity [unit of the quantity]; those not given
        come from :data:`supervisor.virtual.machine.DEFAULT_UNCERTAINTY`.
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current over an edge's life [-], 0 for
        none (see :func:`supervisor.virtual.simulate.run_part`). The catalogue band is read as
        covering the process over an edge's whole life (the paper's data were taken with edges
        at various wear): the new edge's truth of a drifting quantity is drawn so that the worn
        edge's, ``1 + D`` times it, still lies under the band's upper edge.

    Returns
    -------
    VirtualMachine
        The machine, with :class:`supervisor.virtual.machine.TrueProcess` per operation.
    """
    _check_sampling(plan, spread, exponent_spread)
    streams = np.random.default_rng(seed).spawn(len(plan.operations))
    processes: dict[str, TrueProcess] = {}
    for op, rng in zip(plan.operations, streams, strict=True):
        tool = _true_tool(plan, op, rng, seed, spread, exponent_spread, wear_drift_per_edge_life)
        processes[op.name] = TrueProcess(op.name, tool)
    return VirtualMachine(
        plan=plan,
        processes=processes,
        uncertainty={**DEFAULT_UNCERTAINTY, **(uncertainty or {})},
        wear_drift_per_edge_life=wear_drift_per_edge_life,
    )


def _check_sampling(plan: Plan, spread: float, exponent_spread: float) -> None:
    """Refuse a spread that is not a number >= 0 and an operation with a finishing pass."""
    for name, value in (("spread", spread), ("exponent_spread", exponent_spread)):
        if not (math.isfinite(value) and value >= 0):
            raise InputError(name, value, "must be a number >= 0")
    for i, op in enumerate(plan.operations):
        if op.passes is not None and op.passes.finish is not None:  # one setpoint per operation
            raise InputError(
                f"operations[{i}].finish",
                op.passes.finish.depth_mm,
                "the virtual machine makes an operation at one setpoint: a finishing pass is "
                "not simulated (equal passes are; rcb optimize and the REST service take it)",
            )


def _true_tool(
    plan: Plan,
    op: Operation,
    rng: np.random.Generator,
    seed: int,
    spread: float,
    exponent_spread: float,
    drift: float,
) -> Tool:
    """The true tool of ``op``: every model drawn from ``rng`` in quantity-name order."""
    nominal = plan.tools[op.tool]
    wears = drift > 0 and "tool_life_mm3" in nominal.models
    true_models = {
        q: true_model(
            nominal.models[q],
            op,
            rng,
            spread,
            exponent_spread,
            drift if wears and quantities.quantity(q).drifts_with_wear else 0.0,
        )
        for q in sorted(nominal.models)
    }
    return Tool(
        name=nominal.name,
        process=nominal.process,
        models={q: true_models[q] for q in nominal.models},
        description=f"true process of operation {op.name!r} (virtual machine, seed {seed})",
        material=nominal.material,
        source=f"sampled inside the bands of {nominal.source or nominal.name}",
    )


def true_model(
    model: PowerLawModel,
    op: Operation,
    rng: np.random.Generator,
    spread: float,
    exponent_spread: float,
    drift: float = 0.0,
    box: tuple[np.ndarray, np.ndarray] | None = None,
) -> PowerLawModel:
    """One true model inside ``model``'s band over ``op``'s bounds (see :func:`sample_machine`).

    ``drift``: the rise over an edge's life the model will see; the new edge's truth is drawn
    that much under the band's upper edge, so the worn edge's stays inside it too. ``box``:
    ``ln`` of the low and high end of each input (sorted by name) to keep it inside the band
    over, instead of ``op``'s (a tool shared by several operations,
    :mod:`supervisor.virtual.fleet`).
    """
    source = f"true model of {op.name!r}, sampled inside the band of K = {model.K:g} ± {model.dK:g}"
    if model.dK == 0:
        return PowerLawModel(model.quantity, model.K, 0.0, dict(model.exponents), source)
    names = sorted(model.exponents)
    band = model.dK / model.K
    scales = np.array([exponent_spread * abs(model.exponents[n]) for n in names])
    eps = rng.standard_normal(len(names)) * scales
    u = float(rng.random())
    low, high = log_range(names, op) if box is None else box
    # ln(true/nominal) = ln(1 + δ) + Σ ε_i ln x_i must lie in [ln(1 − b), ln(1 + b)]
    ln_lo = math.log1p(-band) + _BAND_MARGIN if band < 1 else -math.inf
    # a drift beyond the band's width cannot fit inside it: the truth at the band's low edge
    ln_hi = max(math.log1p(band) - math.log1p(drift) - _BAND_MARGIN, min(ln_lo, 0.0))
    s_hi = float(np.maximum(eps * low, eps * high).sum())
    s_lo = float(np.minimum(eps * low, eps * high).sum())
    shrink = 1.0
    if s_hi > ln_hi:
        shrink = min(shrink, max(ln_hi, 0.0) / s_hi)
    if s_lo < ln_lo:
        shrink = min(shrink, ln_lo / s_lo)
    eps, s_hi, s_lo = eps * shrink, s_hi * shrink, s_lo * shrink
    # a band wider than K (b >= 1) would allow a truth down to 0: keep K_true > 0
    delta_lo = max(math.expm1(ln_lo - s_lo), -1.0 + 1e-6)
    delta_hi = math.expm1(ln_hi - s_hi)
    delta = _truncated_normal(spread * band, delta_lo, delta_hi, u)
    exponents = {n: model.exponents[n] + float(e) for n, e in zip(names, eps, strict=True)}
    return PowerLawModel(
        model.quantity, model.K * (1.0 + delta), 0.0, exponents, source, model.reference
    )


def log_range(names: list[str], op: Operation) -> tuple[np.ndarray, np.ndarray]:
    """``ln`` of the low and high end of each variable: bounds, or the context value twice."""
    low, high = [], []
    for name in names:
        if name in op.bounds:
            lo, hi = op.bounds[name]
        elif name in op.context:
            lo = hi = op.context[name]
        else:
            raise InputError(f"operations.{op.name}", name, "model input neither bound nor context")
        low.append(math.log(lo))
        high.append(math.log(hi))
    return np.array(low), np.array(high)


def _truncated_normal(sigma: float, low: float, high: float, u: float) -> float:
    """``N(0, σ²)`` truncated to ``[low, high]`` (which holds 0), by inverting its CDF at ``u``."""
    if sigma == 0 or low >= high:
        return min(max(0.0, low), high)
    normal = statistics.NormalDist(0.0, sigma)
    p_lo, p_hi = normal.cdf(low), normal.cdf(high)
    p = min(max(p_lo + u * (p_hi - p_lo), 1e-300), 1.0 - 1e-16)
    return min(max(normal.inv_cdf(p), low), high)


def oracle_tools(machine: VirtualMachine) -> dict[str, Tool]:
    """The true tool of every operation (``dK = 0``), for ``optimize_plan(plan, tools=...)``.

    The optimum with these tools is the fastest any controller could run without crossing a
    true limit (with no setpoint uncertainty in the plan): the oracle.
    """
    return {name: process.tool for name, process in machine.processes.items()}
