r"""The oracle of a faulted truth: the fastest setpoints that meet every *current* true limit.

Without faults the oracle is the plan's optimisation with the true models and no band
(:func:`supervisor.virtual.sampling.oracle_tools`). A step keeps the truth a power law, its
maximum models' ``K`` × FACTOR: the same LP (HiGHS) solves it exactly. A curved truth
(:class:`supervisor.virtual.faults.Bend`) is not a power law, so the log-linear program of
:mod:`supervisor.optimize` cannot pose it; each operation is solved on its own (the plan's
operations share no constraint, and the cycle time is their sum) as the nonlinear program

.. math::

    \max_{x}\ \ln \mathrm{MRR}(x) \quad \text{s.t.} \quad
    \ln y_j^\mathrm{true}(x) = \ln K_j + e_j \cdot x + C b_j(x) + \ln s_j
    \le \ln \mathrm{limit}_j \ (\ge \text{ for tool life}), \quad
    \ln x_\mathrm{lo} \le x \le \ln x_\mathrm{hi}

in ``x = ln`` of the cutting parameters (derived quantities add their own monomial to the
force's), by SciPy's SLSQP with analytic gradients, started from the power-law oracle (the
same truth without the bend, ``C = 0``) and from the middle of the bounds box; the faster
point that meets every true limit wins. SLSQP because the bend is smooth and small (``C``
of a few per cent in ``ln``), so the program is a gently bent LP whose optimum lies near the
power-law one: a local quasi-Newton method from there converges in a few iterations, where
sequential LPs on tangent power laws would need a trust region to stop zig-zagging between
vertices. It is a local optimum; the re-check below is what is promised.

Every oracle is re-checked by making a noise-free part with it on the faulted machine
(:func:`supervisor.virtual.simulate.run_part`): a true limit crossed (beyond
:data:`~supervisor.virtual.machine.VIOLATION_RTOL`) is a :class:`SupervisorError`.

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST): Eqs. 10-13 (the optimisation in
   ``ln`` of the parameters).
.. [2] Kraft (1988), "A software package for sequential quadratic programming", DFVLR-FB
   88-28 (SLSQP, as in ``scipy.optimize.minimize(method="SLSQP")``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize

from models import kinematics
from models.errors import InputError
from models.tool import Tool
from supervisor.errors import SupervisorError
from supervisor.inputs.plan import Operation
from supervisor.optimize.optimizer import optimize_plan
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.virtual.faults import Bend, PartFaults
from supervisor.virtual.machine import CompiledOperation, VirtualMachine
from supervisor.virtual.sampling import oracle_tools
from supervisor.virtual.simulate import run_part

#: The curved program's limits are kept this far inside (in ln), against SLSQP's tolerance.
_INSIDE = 1e-9

LnFunction = Callable[[np.ndarray], tuple[float, np.ndarray]]


def stepped_tools(machine: VirtualMachine, factor: float) -> dict[str, Tool]:
    """The true tools with every maximum model's ``K`` × ``factor`` (tool life unchanged)."""
    tools = oracle_tools(machine)
    if factor == 1.0:
        return tools
    out = {}
    for name, tool in tools.items():
        models = {
            q: replace(m, K=m.K * factor) if m.info.sense == "max" else m
            for q, m in tool.models.items()
        }
        out[name] = replace(tool, models=models)
    return out


def truth_oracle(machine: VirtualMachine, faults: PartFaults | None = None) -> PlanResult:
    """The oracle of ``machine``'s truth with ``faults`` in force (module docstring).

    Parameters
    ----------
    machine : VirtualMachine
        The machine (its truth, without wear drift: the oracle of a new edge).
    faults : PartFaults, optional
        The step factor and bends in force (noise and dropouts do not change the truth).

    Returns
    -------
    PlanResult
        Per operation the oracle's setpoint, MRR and time; a curved operation's ``predicted``
        is empty (its truth is no power law) and its ``binding`` the limits within 1e-6 of
        their value.
    """
    plan = machine.plan
    if faults is None:
        return optimize_plan(plan, tools=oracle_tools(machine))
    power_law = optimize_plan(plan, tools=stepped_tools(machine, faults.step_factor))
    result = power_law
    if any(faults.bends.get(op.name) for op in plan.operations):
        operations = tuple(
            _curved(op, compiled, faults, start)
            for op, compiled, start in zip(
                plan.operations, machine.compiled, power_law.operations, strict=True
            )
        )
        result = replace(power_law, operations=operations)
    _recheck(machine, result, faults)
    return result


def _recheck(machine: VirtualMachine, result: PlanResult, faults: PartFaults) -> None:
    """Make a noise-free part at ``result``'s setpoints; refuse it if a true limit is crossed."""
    setpoints = {op.name: op.setpoint for op in result.operations}
    clean = PartFaults(step_factor=faults.step_factor, bends=faults.bends)
    outcome = run_part(machine, setpoints, np.random.default_rng(0), faults=clean)
    if outcome.violations:
        v = outcome.violations[0]
        raise SupervisorError(
            f"the oracle of the faulted truth crosses {v.operation} {v.quantity}: "
            f"{v.true_value:.6g} against {v.limit:.6g}"
        )


def _ln_functions(compiled: CompiledOperation, faults: PartFaults) -> dict[str, LnFunction]:
    """Per model and derived quantity, ``ln y(x)`` and its gradient on the faulted truth."""
    bends: Mapping[str, Bend] = faults.bends.get(compiled.name, {})
    stepped = {q for q, _, _ in compiled.measured}
    out: dict[str, LnFunction] = {}

    def model(q: str, coefficient: float, exponents: tuple[float, ...]) -> LnFunction:
        ln_k = math.log(coefficient) + (math.log(faults.step_factor) if q in stepped else 0.0)
        e = np.array(exponents)
        bend = bends.get(q)

        def f(x: np.ndarray) -> tuple[float, np.ndarray]:
            if bend is None:
                return ln_k + float(e @ x), e
            return ln_k + float(e @ x) + bend.at(x.tolist()), e + bend.gradient(x.tolist())

        return f

    for q, mono in compiled.models:
        out[q] = model(q, mono.coefficient, mono.exponents)
    for name, base, per in compiled.derived:
        own = model("", per.coefficient, per.exponents)
        under = out.get(base) if base is not None else None

        def derived(
            x: np.ndarray, own: LnFunction = own, under: LnFunction | None = under
        ) -> tuple[float, np.ndarray]:
            value, grad = own(x)
            if under is None:
                return value, grad
            b_value, b_grad = under(x)
            return value + b_value, grad + b_grad

        out[name] = derived
    return out


def _check_curvable(op: Operation) -> None:
    """Refuse an operation the curved oracle cannot solve (not MRR, a domain, passes)."""
    if op.objective != "mrr" or op.domain is not None or op.passes is not None:
        raise InputError(
            "--fault",
            "curvature",
            f"operation {op.name!r}: the curved oracle takes an MRR objective without a "
            "Borangiu domain or passes",
        )


def _curved(
    op: Operation, compiled: CompiledOperation, faults: PartFaults, start: OperationResult
) -> OperationResult:
    """The curved-truth optimum of one operation, by SLSQP from ``start`` and the box middle."""
    _check_curvable(op)
    params = compiled.parameters
    ln = _ln_functions(compiled, faults)
    rows = []
    for lim in compiled.limits:
        sign = 1.0 if lim.sense == "max" else -1.0
        bound = math.log(lim.limit) + math.log(lim.scale) - sign * _INSIDE
        rows.append((ln[lim.value_of], sign, bound))

    def g(x: np.ndarray) -> np.ndarray:
        return np.array([s * (b - f(x)[0]) for f, s, b in rows])

    def g_jac(x: np.ndarray) -> np.ndarray:
        return np.array([-s * f(x)[1] for f, s, _ in rows]).reshape(len(rows), len(x))

    mrr = kinematics.mrr_monomial(op.process).fix(op.context)
    c = np.array([mrr.exponents.get(p, 0.0) for p in params])
    box = [(math.log(op.bounds[p][0]), math.log(op.bounds[p][1])) for p in params]
    starts = [
        np.log([start.setpoint[p] for p in params]),
        np.array([(lo + hi) / 2.0 for lo, hi in box]),
    ]
    best: np.ndarray | None = None
    for x0 in starts:
        solved = minimize(
            lambda x: -float(c @ x),
            x0,
            jac=lambda x: -c,
            method="SLSQP",
            bounds=box,
            constraints=[{"type": "ineq", "fun": g, "jac": g_jac}] if rows else [],
            options={"ftol": 1e-12, "maxiter": 200},
        )
        x = np.clip(solved.x, [lo for lo, _ in box], [hi for _, hi in box])
        if rows and float(g(x).min()) < -_INSIDE:
            continue
        if best is None or float(c @ x) > float(c @ best):
            best = x
    if best is None:
        raise SupervisorError(f"no oracle found for operation {op.name!r} on the curved truth")
    setpoint = {p: float(math.exp(v)) for p, v in zip(params, best, strict=True)}
    rate = mrr.evaluate(setpoint)
    slack = g(best) if rows else np.array([])
    binding = tuple(lim.name for lim, s in zip(compiled.limits, slack, strict=True) if s < 1e-6)
    return replace(
        start,
        setpoint=setpoint,
        predicted={},
        mrr_cm3_min=rate,
        time_min=kinematics.machining_time_min(op.volume_mm3, rate),
        binding=binding,
        fallback=None,
        tool_models=None,
    )
