"""``rcb milling domain``: Borangiu's (feed rate, spindle speed) domain of one pass, both optima.

Reads a domain file (``examples/borangiu_domain.toml``: ``[cut]``, ``[domain]`` with Borangiu's
Eqs. 2-7, ``[productivity]``), solves the largest feed rate (an LP: the largest MRR at the
pass's depth and width) and the least productivity cost ``J`` (a geometric program), and
prints both with the constraints they lie on, Eq. 10's stationary point, and how much more
``J`` the max-MRR point costs. Errors follow ``rcb`` (:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.common import JsonOption, emit, errors
from api.cli.tables import new_table

if TYPE_CHECKING:
    from supervisor.borangiu.result import DomainPoint, DomainResult

_out = Console()


def domain(
    domain_file: Annotated[
        Path,
        typer.Argument(metavar="DOMAIN.toml", help="The pass: [cut], [domain], [productivity]."),
    ],
    as_json: JsonOption = False,
) -> None:
    """Borangiu's (w, n) domain of one pass: max MRR (LP) against least cost J (GP)."""
    # imported here (NumPy, the solvers): rcb --help and the other commands do not load them
    from supervisor.borangiu.problem import load_domain_problem
    from supervisor.optimize.optimizer import optimize_domain

    with errors():
        problem = load_domain_problem(domain_file)
        result = optimize_domain(problem)
    if as_json:
        data = result_json(result)
        data["power_bound_Kp"] = problem.domain.power_bound
        emit(data)
        return
    _out.print(_table(result))
    for line in _summary(result):
        _out.print(line, markup=False, highlight=False)


def point_json(point: DomainPoint) -> dict[str, Any]:
    """One optimum as in ``rcb milling domain --json``."""
    return {
        "feed_rate_mm_min": point.feed_rate_mm_min,
        "spindle_rpm": point.spindle_rpm,
        "pitch_feed_mm_rev": point.pitch_feed_mm_rev,
        "cost_per_kg": point.cost_per_kg,
        "mrr_cm3_min": point.mrr_cm3_min,
        "power_kW": point.power_kW,
        "speed_m_min": point.speed_m_min,
        "tool_life_min": point.tool_life_min,
        "active": list(point.active),
    }


def result_json(result: DomainResult) -> dict[str, Any]:
    """Both optima, the Eq. 10 point and the comparison."""
    c = result.coefficients
    stationary = None
    if result.stationary is not None:
        w0, n0 = result.stationary
        stationary = {"feed_rate_mm_min": w0, "spindle_rpm": n0}
    return {
        "name": result.name,
        "coefficients": {"a": c.a, "b": c.b, "c": c.c, "q": c.q, "m": c.m, "yp": c.yp},
        "max_mrr": point_json(result.max_feed_rate),
        "min_cost": point_json(result.min_cost),
        "mechanical_limit": result.mechanical_limit,
        "stationary_point_eq10": stationary,
        "cost_increase_percent": result.cost_increase_percent,
        "feed_rate_decrease_percent": result.feed_rate_decrease_percent,
    }


def _label(name: str) -> str:
    from models.borangiu_domain import EQUATIONS

    return f"{name.removeprefix('domain.')} ({EQUATIONS.get(name, '')})"


def _fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


_OPTIMA = (("max MRR", "max_feed_rate"), ("min J", "min_cost"))


def _table(result: DomainResult) -> Table:
    table = new_table(title=f"{result.name}: Borangiu's (w, n) domain")
    headings = ("optimum", "w\nmm/min", "n\nrpm", "w/n\nmm/rev", "J\n/kg", "MRR\ncm³/min", "P\nkW")
    for heading in headings:
        table.add_column(heading, justify="left" if heading == "optimum" else "right")
    for title, attribute in _OPTIMA:
        p: DomainPoint = getattr(result, attribute)
        values = (p.feed_rate_mm_min, p.spindle_rpm, p.pitch_feed_mm_rev, p.cost_per_kg)
        table.add_row(title, *map(_fmt, (*values, p.mrr_cm3_min, p.power_kW)))
    return table


def _summary(result: DomainResult) -> list[str]:
    c = result.coefficients
    lines = [
        f"{title} lies on: " + ", ".join(_label(n) for n in getattr(result, attribute).active)
        for title, attribute in _OPTIMA
    ]
    lines.append(
        f"J(w, n) = {c.a:.4g}·w^{c.q / c.m - 1:.4g}·n^{(1 - c.q) / c.m:.4g}"
        f" + {c.b:.4g}·w^{c.yp - 1:.4g}·n^{1 - c.yp:.4g} + {c.c:.4g}/w [/kg]"
    )
    if result.stationary is not None and result.mechanical_limit is not None:
        w0, n0 = result.stationary
        lines.append(
            f"Eq. 10 on {_label(result.mechanical_limit)}: w0 = {w0:.4g} mm/min, n0 = {n0:.4g} rpm"
        )
    lines.append(
        f"J at the max-MRR point is {result.cost_increase_percent:.3g} % above the J optimum, "
        f"which feeds {result.feed_rate_decrease_percent:.3g} % slower"
    )
    return lines
