"""The optima of Borangiu's (w, n) problem, and Eq. 10's stationary point to compare them with.

Eqs. 8-12: with a single mechanical-load constraint ``g = C_1 w − n <= 0`` (``C_1 = 1/K``
with ``K`` the tightest of ``K_t, K_d, K_fM``) the minimum of ``J`` is the stationary point of
Eq. 10, ``w_0 = C_1^(q−1) S^m``, ``n_0 = C_1^q S^m``, ``S = m c / ((1 − m) a)``: the
intersection of the line ``n = C_1 w`` with the curve (12) ``w^q n^(1−q) = S^m``. On that line
the energy term of ``J`` is constant and the rest is ``a C_1^((1−q)/m) w^(1/m−1) + c/w``.
Readings: the paper numbers two equations (9) (the matrix G and ``g(w, n)``) and calls Fig. 6
"Fig. x"; Eq. 10 is used as printed, which this derivation confirms.

References
----------
.. [1] Borangiu et al., Embedded numeric-adaptive machining control based on data fusion,
   IFAC 2007, Eqs. 2-7, 9-12, Figs. 6-7.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from models.borangiu_cost import FEED_RATE, SPINDLE, Coefficients, evaluate, wn_terms
from supervisor.borangiu.problem import DomainProblem
from supervisor.errors import SolverError


@dataclass(frozen=True)
class DomainPoint:
    """One point of the (w, n) domain with what follows from it.

    ``active`` names the constraints (``domain.<field>``) the point lies on; ``power_kW``
    needs the power law, ``mrr_cm3_min`` and ``speed_m_min`` the pass geometry,
    ``tool_life_min`` the cost data.
    """

    feed_rate_mm_min: float
    spindle_rpm: float
    pitch_feed_mm_rev: float
    cost_per_kg: float
    power_kW: float | None
    active: tuple[str, ...]
    mrr_cm3_min: float | None = None
    speed_m_min: float | None = None
    tool_life_min: float | None = None


@dataclass(frozen=True)
class DomainResult:
    """Both optima of a :class:`DomainProblem` and the Eq. 10 stationary point.

    ``max_feed_rate``: the largest ``w`` (an LP; the largest MRR at the pass's depth and
    width), and among such points the one of least ``J``. ``min_cost``: the least ``J`` (a GP).
    ``stationary``: Eq. 10's ``(w_0, n_0)`` on the tightest mechanical-load line
    ``mechanical_limit``, inside the domain or not; ``None`` without such a limit.
    """

    name: str
    coefficients: Coefficients
    max_feed_rate: DomainPoint
    min_cost: DomainPoint
    mechanical_limit: str | None
    stationary: tuple[float, float] | None

    @property
    def cost_increase_percent(self) -> float:
        """How much more ``J`` is at the max-feed point than at the ``J`` optimum [%]."""
        least = self.min_cost.cost_per_kg
        return 100.0 * (self.max_feed_rate.cost_per_kg - least) / least

    @property
    def feed_rate_decrease_percent(self) -> float:
        """How much lower ``w`` (and the MRR) is at the ``J`` optimum [%]."""
        most = self.max_feed_rate.feed_rate_mm_min
        return 100.0 * (most - self.min_cost.feed_rate_mm_min) / most


def stationary_point(
    coefficients: Coefficients, max_pitch_feed_mm_rev: float
) -> tuple[float, float]:
    r"""Borangiu Eq. 10 on the line ``w = K n`` (``C_1 = 1/K``): ``(w_0, n_0)`` [mm/min, rpm].

    .. math:: w_0 = C_1^{q-1} S^m, \quad n_0 = C_1^q S^m, \quad S = \frac{m c}{(1-m) a}
    """
    a, c, q, m = coefficients.a, coefficients.c, coefficients.q, coefficients.m
    scale = (m * c / ((1.0 - m) * a)) ** m
    c1 = 1.0 / max_pitch_feed_mm_rev
    return c1 ** (q - 1.0) * scale, c1**q * scale


def domain_point(
    problem: DomainProblem, point: Mapping[str, float], binding: tuple[str, ...]
) -> DomainPoint:
    """Evaluate a point ``{feed_rate_mm_min, spindle_rpm}`` of ``problem``."""
    w, n = point[FEED_RATE], point[SPINDLE]
    power = problem.domain.power_kW(w, n)
    cut, cost = problem.cut, problem.cost
    speed = math.pi * cut.tool_diameter_mm * n / 1000.0 if cut else None
    life = None
    if cut is not None and cost is not None and speed is not None:
        fz = w / (n * cut.flute_count)
        life = (cost.taylor_speed_m_min / (speed * fz**cost.taylor_q)) ** (1.0 / cost.taylor_m)
    return DomainPoint(
        feed_rate_mm_min=w,
        spindle_rpm=n,
        pitch_feed_mm_rev=w / n,
        cost_per_kg=evaluate(wn_terms(problem.coefficients), point),
        power_kW=power,
        active=tuple(name for name in binding if name.startswith("domain.")),
        mrr_cm3_min=w * cut.axial_depth_mm * cut.radial_depth_mm / 1000.0 if cut else None,
        speed_m_min=speed,
        tool_life_min=life,
    )


def domain_result(
    problem: DomainProblem, max_feed_rate: DomainPoint, min_cost: DomainPoint
) -> DomainResult:
    """Both optima; refuses a ``J`` optimum costlier than the max-feed point (solver check)."""
    if min_cost.cost_per_kg > max_feed_rate.cost_per_kg * (1.0 + 1e-6):
        raise SolverError(
            f"domain {problem.name!r}: the J optimum {min_cost.cost_per_kg:.6g} is above J at "
            f"the max-feed point {max_feed_rate.cost_per_kg:.6g}"
        )
    load = problem.domain.max_load_feed()
    return DomainResult(
        name=problem.name,
        coefficients=problem.coefficients,
        max_feed_rate=max_feed_rate,
        min_cost=min_cost,
        mechanical_limit=load[0] if load else None,
        stationary=stationary_point(problem.coefficients, load[1]) if load else None,
    )
