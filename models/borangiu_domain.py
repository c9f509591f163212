"""Borangiu's allowable (feed rate, spindle speed) domain, Eqs. 2-7, as monomial limits.

The six constraints of Borangiu et al. on the feed rate ``w`` [mm/min] and the spindle speed
``n`` [rpm] are monomial inequalities, so each is one row of the log-linear program:

- (2) torsion torque, (3) deflection torque, (4) pitch feed: bounds on ``w/n`` [mm/rev]
  (``K_t``, ``K_d``, ``K_fm <= w/n <= K_fM``); in milling ``w/n = f_z z``,
- (5) feed drive ``w_min <= w <= w_max``, (6) spindle ``n_min <= n <= n_max``,
- (7) main-drive power ``w^yp n^(1−yp) <= K_p``. The paper gives only ``K_p``; here the power
  law is ``P = k_P w^yp n^(1−yp)`` [kW] with a maximum ``P_max``, so ``K_p = P_max / k_P``, and
  the same ``k_P, yp`` give the energy term of ``J`` (:mod:`models.borangiu_cost`).

Each constant is a field of :class:`Domain` named with its unit; a plan operation's
``[operations.domain]`` adds them as rows in ``ln(ap, ae, fz, vc)``
(:func:`milling_limits`), and Borangiu's own problem in ``ln(w, n)``
(:mod:`supervisor.borangiu.problem`) uses them as :func:`wn_limits`.

References
----------
.. [1] Borangiu et al., Embedded numeric-adaptive machining control based on data fusion,
   IFAC 2007, Eqs. 2-7, 9-12, Figs. 6-7.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from models import fields as checked
from models import kinematics
from models.borangiu_cost import FEED_RATE, SPINDLE, monomial_power
from models.errors import InputError
from models.monomial import Monomial
from models.quantities import Sense


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
