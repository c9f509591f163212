"""Borangiu's allowable (feed rate, spindle speed) domain, Eqs. 2-7, and the (w, n) problem.

The six constraints of Borangiu et al. on the feed rate ``w`` [mm/min] and the spindle speed
``n`` [rpm] are monomial inequalities, so each is one row of the log-linear program:

- (2) torsion torque, (3) deflection torque, (4) pitch feed: bounds on ``w/n`` [mm/rev]
  (``K_t``, ``K_d``, ``K_fm <= w/n <= K_fM``); in milling ``w/n = f_z z``,
- (5) feed drive ``w_min <= w <= w_max``, (6) spindle ``n_min <= n <= n_max``,
- (7) main-drive power ``w^yp n^(1−yp) <= K_p``. The paper gives only ``K_p``; here the power
  law is ``P = k_P w^yp n^(1−yp)`` [kW] with a maximum ``P_max``, so ``K_p = P_max / k_P``, and
  the same ``k_P, yp`` give the energy term of ``J`` (:mod:`supervisor.borangiu.productivity`).

Each constant is a field of :class:`Domain` named with its unit; a plan operation's
``[operations.domain]`` adds them as rows in ``ln(ap, ae, fz, vc)``, and a domain file
(:func:`load_domain_problem`) poses Borangiu's own problem in ``ln(w, n)`` for one pass of fixed
depth and width: the largest feed rate (an LP: the largest MRR) and the least ``J`` (a GP).

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
from dataclasses import dataclass, fields
from pathlib import Path

from models import fields as checked
from models import kinematics
from models.errors import InputError
from models.monomial import Monomial
from models.quantities import Sense
from supervisor.borangiu.productivity import (
    FEED_RATE,
    SPINDLE,
    Coefficients,
    CostData,
    coefficients_from_cost,
    evaluate,
    monomial_power,
    productivity_from_mapping,
    wn_terms,
)
from supervisor.errors import SolverError
from supervisor.inputs.files import read_toml


@dataclass(frozen=True)
class Domain:
    """Borangiu's constraints (2)-(7); ``None``: not constrained.

    Parameters
    ----------
    max_torque_feed_mm_rev : float, optional
        ``K_t``: the pitch feed ``w/n`` at which the spindle torsion torque reaches its maximum
        [mm/rev] (Eq. 2).
    max_deflection_feed_mm_rev : float, optional
        ``K_d``: the pitch feed of the maximum deflection torque [mm/rev] (Eq. 3).
    min_pitch_feed_mm_rev, max_pitch_feed_mm_rev : float, optional
        ``K_fm, K_fM``: pitch-feed range [mm/rev] (Eq. 4).
    min_feed_rate_mm_min, max_feed_rate_mm_min : float, optional
        ``w_min, w_max``: feed-drive range [mm/min] (Eq. 5).
    min_spindle_rpm, max_spindle_rpm : float, optional
        ``n_min, n_max``: spindle range [rpm] (Eq. 6).
    power_exponent : float, optional
        ``yp`` of ``P = k_P w^yp n^(1−yp)``, ``0 < yp < 1`` [-] (Eq. 7).
    power_coefficient_kW : float, optional
        ``k_P`` [kW / ((mm/min)^yp rpm^(1−yp))].
    max_power_kW : float, optional
        ``P_max`` [kW]; ``K_p = P_max / k_P``.
    """

    max_torque_feed_mm_rev: float | None = None
    max_deflection_feed_mm_rev: float | None = None
    min_pitch_feed_mm_rev: float | None = None
    max_pitch_feed_mm_rev: float | None = None
    min_feed_rate_mm_min: float | None = None
    max_feed_rate_mm_min: float | None = None
    min_spindle_rpm: float | None = None
    max_spindle_rpm: float | None = None
    power_exponent: float | None = None
    power_coefficient_kW: float | None = None
    max_power_kW: float | None = None

    @property
    def power_bound(self) -> float | None:
        """Borangiu's ``K_p = P_max / k_P`` [(mm/min)^yp rpm^(1−yp)] (Eq. 7)."""
        if self.max_power_kW is None or self.power_coefficient_kW is None:
            return None
        return self.max_power_kW / self.power_coefficient_kW

    def max_load_feed(self) -> tuple[str, float] | None:
        """The tightest "mechanical load" limit on ``w/n`` (Eqs. 2-4 right): name and value."""
        given = [(f"domain.{k}", getattr(self, k)) for k in _MECHANICAL]
        present = [(name, value) for name, value in given if value is not None]
        return min(present, key=lambda item: item[1]) if present else None

    def power_kW(self, feed_rate_mm_min: float, spindle_rpm: float) -> float | None:
        """``P = k_P w^yp n^(1−yp)`` [kW], when the power law is given."""
        if self.power_exponent is None or self.power_coefficient_kW is None:
            return None
        yp = self.power_exponent
        power: float = self.power_coefficient_kW * feed_rate_mm_min**yp * spindle_rpm ** (1 - yp)
        return power


_MECHANICAL = ("max_torque_feed_mm_rev", "max_deflection_feed_mm_rev", "max_pitch_feed_mm_rev")
_POWER = ("power_exponent", "power_coefficient_kW", "max_power_kW")
#: Field, equation, bounded quantity, sense.
_LIMITS: tuple[tuple[str, str, str, Sense], ...] = (
    ("max_torque_feed_mm_rev", "Eq. 2", "pitch", "max"),
    ("max_deflection_feed_mm_rev", "Eq. 3", "pitch", "max"),
    ("min_pitch_feed_mm_rev", "Eq. 4", "pitch", "min"),
    ("max_pitch_feed_mm_rev", "Eq. 4", "pitch", "max"),
    ("min_feed_rate_mm_min", "Eq. 5", "feed", "min"),
    ("max_feed_rate_mm_min", "Eq. 5", "feed", "max"),
    ("min_spindle_rpm", "Eq. 6", "spindle", "min"),
    ("max_spindle_rpm", "Eq. 6", "spindle", "max"),
    ("max_power_kW", "Eq. 7", "power", "max"),
)
_PAIRS = (
    ("min_pitch_feed_mm_rev", "max_pitch_feed_mm_rev"),
    ("min_feed_rate_mm_min", "max_feed_rate_mm_min"),
    ("min_spindle_rpm", "max_spindle_rpm"),
)
#: Borangiu's equation of each constraint, by its name (``domain.<field>``).
EQUATIONS = {f"domain.{name}": eq for name, eq, _, _ in _LIMITS}


def domain_from_mapping(data: object, path: str) -> Domain:
    """Read a ``[domain]`` table; every error names ``path.<field>`` and its value."""
    table = checked.mapping(data, path)
    keys = [f.name for f in fields(Domain)]
    checked.only_keys(table, keys, path)
    if not table:
        raise InputError(path, {}, f"give at least one of: {', '.join(keys)}")
    values = {k: checked.number(v, f"{path}.{k}", positive=True) for k, v in table.items()}
    if any(k in values for k in _POWER):
        for key in _POWER:
            if key not in values:
                raise InputError(f"{path}.{key}", None, "Eq. 7 needs all of: " + ", ".join(_POWER))
        if not values["power_exponent"] < 1:
            raise InputError(
                f"{path}.power_exponent", table["power_exponent"], "must lie in (0, 1) (Eq. 7)"
            )
    for low, high in _PAIRS:
        if low in values and high in values and values[low] > values[high]:
            raise InputError(
                f"{path}.{low}", table[low], f"is above {path}.{high} = {values[high]:g}"
            )
    return Domain(**values)


@dataclass(frozen=True)
class DomainLimit:
    """One of Borangiu's constraints as a monomial bound.

    ``name`` is ``domain.<field>``; ``monomial`` the bounded quantity in the problem's
    variables; ``limit`` its bound in that quantity's unit; ``equation`` Borangiu's number.
    """

    name: str
    monomial: Monomial
    limit: float
    sense: Sense
    equation: str


def domain_limits(
    domain: Domain, pitch_feed: Monomial, feed_rate: Monomial, spindle: Monomial
) -> tuple[DomainLimit, ...]:
    """Every given constraint of ``domain`` with ``w/n``, ``w`` and ``n`` as these monomials."""
    quantities = {"pitch": pitch_feed, "feed": feed_rate, "spindle": spindle}
    if domain.power_exponent is not None and domain.power_coefficient_kW is not None:
        yp = domain.power_exponent
        power = monomial_power(feed_rate, yp) * monomial_power(spindle, 1.0 - yp)
        quantities["power"] = power.scaled(domain.power_coefficient_kW)
    limits = []
    for name, equation, quantity, sense in _LIMITS:
        value = getattr(domain, name)
        if value is not None:
            monomial = quantities[quantity]
            limits.append(DomainLimit(f"domain.{name}", monomial, value, sense, equation))
    return tuple(limits)


def milling_limits(domain: Domain) -> tuple[DomainLimit, ...]:
    """The constraints in the milling parameters: ``w/n = f_z z``, ``w = f_z z n``."""
    return domain_limits(
        domain,
        Monomial(1.0, {"feed_per_tooth_mm": 1.0, "flute_count": 1.0}),
        kinematics.feed_rate_monomial("milling"),
        kinematics.spindle_rpm_monomial("milling"),
    )


def wn_limits(domain: Domain) -> tuple[DomainLimit, ...]:
    """The constraints in Borangiu's own variables ``feed_rate_mm_min`` and ``spindle_rpm``."""
    w, n = Monomial(1.0, {FEED_RATE: 1.0}), Monomial(1.0, {SPINDLE: 1.0})
    return domain_limits(domain, w * monomial_power(n, -1.0), w, n)


# --- Borangiu's (w, n) problem for one pass ---------------------------------------------------


@dataclass(frozen=True)
class Cut:
    """The fixed geometry of one roughing pass: tool and engagement [mm], flutes [-]."""

    tool_diameter_mm: float
    flute_count: float
    axial_depth_mm: float
    radial_depth_mm: float


@dataclass(frozen=True)
class DomainProblem:
    """Borangiu's problem for one pass: the domain, ``J``'s coefficients, the geometry.

    ``cut`` gives the MRR and speed of a point and is required with ``cost``; ``cost`` is the
    cost data ``coefficients`` were derived from, if they were.
    """

    name: str
    domain: Domain
    coefficients: Coefficients
    cut: Cut | None = None
    cost: CostData | None = None
    description: str = ""


#: Eqs. 5-6 bound the (w, n) program.
_WN_BOUNDS = ("min_feed_rate_mm_min", "max_feed_rate_mm_min", "min_spindle_rpm", "max_spindle_rpm")


def load_domain_problem(path: Path) -> DomainProblem:
    """Read a domain file (TOML: ``name``, ``[cut]``, ``[domain]``, ``[productivity]``)."""
    return domain_problem_from_mapping(read_toml(path, "domain file"))


def domain_problem_from_mapping(data: object) -> DomainProblem:
    """Build and check a :class:`DomainProblem` from its TOML/JSON structure."""
    table = checked.mapping(data, "domain file")
    checked.only_keys(table, ("name", "description", "cut", "domain", "productivity"), "")
    for key in ("domain", "productivity"):
        if key not in table:
            raise InputError(key, None, "required table missing")
    domain = domain_from_mapping(table["domain"], "domain")
    for key in _WN_BOUNDS:
        if getattr(domain, key) is None:
            raise InputError(f"domain.{key}", None, "required: Eqs. 5-6 bound the (w, n) domain")
    yp, k_p = domain.power_exponent, domain.power_coefficient_kW
    if yp is None or k_p is None:  # all three or none (domain_from_mapping)
        raise InputError("domain.power_exponent", None, "required: Eq. 7, the power law")
    cut = _cut(table["cut"]) if "cut" in table else None
    given = productivity_from_mapping(table["productivity"], "productivity", power_exponent=yp)
    cost = given if isinstance(given, CostData) else None
    if isinstance(given, Coefficients):
        coefficients = given
    elif cut is None:
        raise InputError("cut", None, "required with the cost data: J depends on the pass")
    else:
        coefficients = coefficients_from_cost(
            given,
            tool_diameter_mm=cut.tool_diameter_mm,
            flute_count=cut.flute_count,
            axial_depth_mm=cut.axial_depth_mm,
            radial_depth_mm=cut.radial_depth_mm,
            power_exponent=yp,
            power_coefficient_kW=k_p,
        )
    return DomainProblem(
        name=checked.text(table, "name", ""),
        domain=domain,
        coefficients=coefficients,
        cut=cut,
        cost=cost,
        description=checked.text(table, "description", "", default=""),
    )


def _cut(data: object) -> Cut:
    table = checked.mapping(data, "cut")
    keys = [f.name for f in fields(Cut)]
    checked.only_keys(table, keys, "cut")
    for key in keys:
        if key not in table:
            raise InputError(f"cut.{key}", None, "required field missing")
    values = {k: checked.number(v, f"cut.{k}", positive=True) for k, v in table.items()}
    if not values["flute_count"].is_integer():
        raise InputError("cut.flute_count", table["flute_count"], "must be a whole number")
    return Cut(**values)


# --- results -----------------------------------------------------------------------------------


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
