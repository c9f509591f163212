r"""Borangiu's productivity cost ``J``: a posynomial in the cutting parameters.

Minimised as a geometric program by :mod:`supervisor.optimize.productivity`.

Borangiu et al. take Milner's productivity (Eq. 1): the mass removed in one tool life over what
that tool life costs,

.. math::

    I = \frac{K w B \Delta \rho T}{C_s + k_s C_e P_s t_s + C_t (t_r + T) + C_e P_c T},

and minimise ``J = 1/I``. Dividing by ``T`` it is the cost of one minute of cutting over the
mass removed in that minute,

.. math::

    J = \frac{(C_s + C_e P_s t_s / 60 + C_t t_r) / T + C_t + C_e P_c / 60}
             {10^{-6} \rho B \Delta w} \quad [\text{currency/kg}],

and with Taylor's extended tool life ``v T^m f_z^q = C`` (Shaw 1986, ch. 19) and the main-drive
power ``P_c = k_P w^{y_p} n^{1-y_p}`` (Borangiu Eq. 7) it is the posynomial of the paper,
``J(w, n) = a w^{q/m-1} n^{(1-q)/m} + b w^{y_p-1} n^{1-y_p} + c w^{-1}``, with

.. math::

    a = \frac{C_s + C_e P_s t_s/60 + C_t t_r}{10^{-6} \rho B \Delta}
        \left(\frac{\pi D}{1000\, z^q C}\right)^{1/m}, \quad
    b = \frac{C_e k_P}{60 \cdot 10^{-6} \rho B \Delta}, \quad
    c = \frac{C_t}{10^{-6} \rho B \Delta}

(``v = π D n / 1000``, ``f_z = w / (z n)``). Readings of Eq. (1), which is partly misprinted:

- ``k_s C_s P_s t_s`` is read as the energy of a tool change, ``C_e P_s t_s / 60``: a tool cost
  times a power has no meaning, and ``k_s = 1/60`` turns kW·min into kWh. The cutting energy
  ``C_e P_c T`` gets the same ``1/60`` (``T`` is in minutes, ``C_e`` per kWh).
- ``K = 10^-6`` turns mm³ × t/m³ into kg, so ``I`` is in kg per currency unit and ``J`` in
  currency per kg. The wage during the tool change itself is not in Eq. (1); it is left out.
- The paper says ``q, m, yp`` come from Taylor's formula; ``yp`` is the power law's exponent
  (Eq. 7), the same one in ``J``'s energy term.

In the main optimiser the depths are free too, so ``J`` is built in the cutting parameters
(``ap, ae, fz, vc``) with ``P_c`` the nominal ``F·v/60000`` of the tool's force model.

References
----------
.. [1] Borangiu et al., Embedded numeric-adaptive machining control based on data fusion,
   IFAC 2007, Eq. 1, Eq. 7 and ``J(w, n)``.
.. [2] Milner, Adaptive control of feedrate in the milling process, IJMTDR 14 (1974).
.. [3] Shaw, Metal Cutting Principles, ch. 19 (Taylor's extended tool-life equation).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from models import fields, kinematics
from models.errors import InputError
from models.monomial import Monomial

#: Eq. (1)'s ``K``: kg per (mm³ · t/m³).
KG_PER_MM3_T_M3 = 1e-6
#: Eq. (1)'s ``k_s``: hours per minute (kW·min to kWh).
HOURS_PER_MIN = 1.0 / 60.0

#: Variable names of Borangiu's (w, n) problem.
FEED_RATE = "feed_rate_mm_min"
SPINDLE = "spindle_rpm"


@dataclass(frozen=True)
class CostData:
    """The cost data of Borangiu Eq. (1) and Taylor's extended tool-life constants.

    Parameters
    ----------
    tool_cost : float
        ``C_s``, cost of one tool life (tool or edge) [currency].
    wage_rate_per_min : float
        ``C_t``, worker's wage rate [currency/min].
    density_t_m3 : float
        ``ρ``, density of the work material [t/m³].
    taylor_speed_m_min : float
        ``C`` of ``v T^m f_z^q = C``: cutting speed for a 1 min life at ``f_z = 1`` mm
        [m/min · min^m · mm^q].
    taylor_m : float
        ``m``, tool-life exponent, ``0 < m < 1`` [-].
    taylor_q : float
        ``q``, feed exponent, ``0 <= q < 1`` [-].
    energy_cost_per_kWh : float
        ``C_e`` [currency/kWh].
    tool_change_power_kW : float
        ``P_s``, power drawn during a tool change [kW].
    tool_change_time_min : float
        ``t_s`` [min].
    regrinding_time_min : float
        ``t_r``, paid at the wage rate [min].
    """

    tool_cost: float
    wage_rate_per_min: float
    density_t_m3: float
    taylor_speed_m_min: float
    taylor_m: float
    taylor_q: float
    energy_cost_per_kWh: float = 0.0
    tool_change_power_kW: float = 0.0
    tool_change_time_min: float = 0.0
    regrinding_time_min: float = 0.0

    @property
    def cost_per_tool_life(self) -> float:
        """``C_s + C_e P_s t_s / 60 + C_t t_r``: what one tool life costs besides cutting."""
        change_energy = self.energy_cost_per_kWh * self.tool_change_power_kW
        return (
            self.tool_cost
            + change_energy * self.tool_change_time_min * HOURS_PER_MIN
            + self.wage_rate_per_min * self.regrinding_time_min
        )

    def min_cost_tool_life_min(self) -> float:
        """Tool life of least cost ``(1/m − 1)·cost_per_tool_life / C_t`` [min].

        The classical result (Shaw ch. 19) that Borangiu Eq. 10 reproduces on a line of
        constant pitch feed: there the energy term of ``J`` is constant.
        """
        return (1.0 / self.taylor_m - 1.0) * self.cost_per_tool_life / self.wage_rate_per_min


@dataclass(frozen=True)
class Coefficients:
    """``J(w, n) = a w^(q/m−1) n^((1−q)/m) + b w^(yp−1) n^(1−yp) + c w^−1`` [currency/kg].

    ``w`` [mm/min], ``n`` [rpm]; ``a, b, c`` carry whatever units make each term currency/kg.
    """

    a: float
    b: float
    c: float
    q: float
    m: float
    yp: float


_COST_REQUIRED = (
    "tool_cost",
    "wage_rate_per_min",
    "density_t_m3",
    "taylor_speed_m_min",
    "taylor_m",
    "taylor_q",
)
_COST_OPTIONAL = (
    "energy_cost_per_kWh",
    "tool_change_power_kW",
    "tool_change_time_min",
    "regrinding_time_min",
)
_COEFFICIENT_KEYS = ("a", "b", "c", "q", "m", "yp")


def productivity_from_mapping(
    data: object, path: str, *, power_exponent: float | None = None
) -> CostData | Coefficients:
    """Read a ``[productivity]`` table: the cost data, or ``a, b, c, q, m, yp`` directly.

    ``power_exponent`` is the ``yp`` of the domain's power law (Eq. 7), if it has one: the
    coefficients may then leave ``yp`` out, and may not give another value.
    """
    table = fields.mapping(data, path)
    fields.only_keys(table, (*_COST_REQUIRED, *_COST_OPTIONAL, *_COEFFICIENT_KEYS), path)
    given_coefficients = [k for k in _COEFFICIENT_KEYS if k in table]
    if given_coefficients:
        other = next((k for k in table if k not in _COEFFICIENT_KEYS), None)
        if other is not None:
            raise InputError(
                f"{path}.{other}",
                table[other],
                "give either the cost data or the coefficients a, b, c, q, m, yp, not both",
            )
        return _coefficients(table, path, power_exponent)
    for key in _COST_REQUIRED:
        if key not in table:
            raise InputError(f"{path}.{key}", None, "required field missing")
    values = {k: fields.number(v, f"{path}.{k}", minimum=0.0) for k, v in table.items()}
    for key in ("tool_cost", "wage_rate_per_min", "density_t_m3", "taylor_speed_m_min"):
        if values[key] <= 0:
            raise InputError(f"{path}.{key}", table[key], "must be greater than 0")
    _exponents(values["taylor_m"], values["taylor_q"], table, path, "taylor_m", "taylor_q")
    return CostData(**values)


def _coefficients(
    table: Mapping[str, Any], path: str, power_exponent: float | None
) -> Coefficients:
    for key in ("a", "b", "c", "q", "m"):
        if key not in table:
            raise InputError(f"{path}.{key}", None, "required with the coefficients form")
    values = {k: fields.number(v, f"{path}.{k}") for k, v in table.items()}
    for key in ("a", "c"):
        if values[key] <= 0:
            raise InputError(f"{path}.{key}", table[key], "must be greater than 0")
    if values["b"] < 0:
        raise InputError(f"{path}.b", table["b"], "must be at least 0")
    _exponents(values["m"], values["q"], table, path, "m", "q")
    yp = values.get("yp", power_exponent)
    if yp is None:
        raise InputError(f"{path}.yp", None, "required: the power exponent of Eq. 7")
    if not 0 < yp < 1:
        raise InputError(f"{path}.yp", yp, "the power exponent must lie in (0, 1)")
    if power_exponent is not None and yp != power_exponent:
        raise InputError(
            f"{path}.yp",
            table["yp"],
            f"differs from the domain's power_exponent {power_exponent:g}: J's energy term "
            "and the power limit (Eq. 7) share yp",
        )
    return Coefficients(values["a"], values["b"], values["c"], values["q"], values["m"], yp)


def _exponents(
    m: float, q: float, table: Mapping[str, Any], path: str, m_key: str, q_key: str
) -> None:
    if not 0 < m < 1:
        raise InputError(
            f"{path}.{m_key}", table[m_key], "Taylor's exponent must lie in (0, 1) (Eq. 10)"
        )
    if not 0 <= q < 1:
        raise InputError(
            f"{path}.{q_key}",
            table[q_key],
            "Taylor's feed exponent must lie in [0, 1): with q >= 1 a larger pitch feed "
            "would not lower J (Borangiu Eqs. 10-12)",
        )


def monomial_power(monomial: Monomial, exponent: float) -> Monomial:
    """``monomial ** exponent``, again a monomial."""
    return Monomial(
        monomial.coefficient**exponent,
        {name: e * exponent for name, e in monomial.exponents.items()},
    )


def inverse_tool_life(
    cost: CostData, speed_m_min: Monomial, feed_per_tooth_mm: Monomial
) -> Monomial:
    """``1/T = (v f_z^q / C)^(1/m)`` [1/min] from ``v T^m f_z^q = C`` (Shaw ch. 19)."""
    rate = speed_m_min * monomial_power(feed_per_tooth_mm, cost.taylor_q)
    return monomial_power(rate.scaled(1.0 / cost.taylor_speed_m_min), 1.0 / cost.taylor_m)


def cost_terms(
    cost: CostData,
    *,
    removal_mm3_min: Monomial,
    speed_m_min: Monomial,
    feed_per_tooth_mm: Monomial,
    cutting_power_kW: Monomial | None,
) -> tuple[Monomial, ...]:
    """The terms of ``J`` [currency/kg]: tool life, wage, and (with a power) cutting energy.

    Parameters
    ----------
    cost : CostData
        Eq. (1)'s cost data and Taylor's constants.
    removal_mm3_min : Monomial
        Volume removal rate ``w B Δ`` [mm³/min].
    speed_m_min, feed_per_tooth_mm : Monomial
        Cutting speed [m/min] and feed per tooth [mm], for Taylor's tool life.
    cutting_power_kW : Monomial or None
        ``P_c`` [kW]; required when the energy cost is not 0.
    """
    per_kg = monomial_power(removal_mm3_min.scaled(KG_PER_MM3_T_M3 * cost.density_t_m3), -1.0)
    terms = [
        inverse_tool_life(cost, speed_m_min, feed_per_tooth_mm).scaled(cost.cost_per_tool_life)
        * per_kg,
        per_kg.scaled(cost.wage_rate_per_min),
    ]
    if cost.energy_cost_per_kWh > 0:
        if cutting_power_kW is None:
            raise InputError("energy_cost_per_kWh", cost.energy_cost_per_kWh, "needs P_c")
        energy = cost.energy_cost_per_kWh * HOURS_PER_MIN
        terms.append(cutting_power_kW.scaled(energy) * per_kg)
    return tuple(terms)


def milling_cost_terms(cost: CostData, cutting_power_kW: Monomial | None) -> tuple[Monomial, ...]:
    """``J`` [currency/kg] in the milling parameters ``ap, ae, fz, vc`` (context still named).

    ``cutting_power_kW`` is the nominal force model times ``v/60000``, or ``None`` without a
    force model (then the energy cost must be 0).
    """
    return cost_terms(
        cost,
        removal_mm3_min=kinematics.mrr_monomial("milling").scaled(1000.0),
        speed_m_min=Monomial(1.0, {"speed_m_min": 1.0}),
        feed_per_tooth_mm=Monomial(1.0, {"feed_per_tooth_mm": 1.0}),
        cutting_power_kW=cutting_power_kW,
    )


def coefficients_from_cost(
    cost: CostData,
    *,
    tool_diameter_mm: float,
    flute_count: float,
    axial_depth_mm: float,
    radial_depth_mm: float,
    power_exponent: float,
    power_coefficient_kW: float,
) -> Coefficients:
    """``a, b, c, q, m, yp`` of ``J(w, n)`` from the cost data, for one pass (module doc)."""
    w = Monomial(1.0, {FEED_RATE: 1.0})
    n = Monomial(1.0, {SPINDLE: 1.0})
    power = monomial_power(w, power_exponent) * monomial_power(n, 1.0 - power_exponent)
    tool, wage, *energy = cost_terms(
        cost,
        removal_mm3_min=w.scaled(axial_depth_mm * radial_depth_mm),
        speed_m_min=n.scaled(math.pi * tool_diameter_mm / 1000.0),
        feed_per_tooth_mm=w * monomial_power(n, -1.0).scaled(1.0 / flute_count),
        cutting_power_kW=power.scaled(power_coefficient_kW),
    )
    b = energy[0].coefficient if energy else 0.0
    return Coefficients(
        tool.coefficient, b, wage.coefficient, cost.taylor_q, cost.taylor_m, power_exponent
    )


def wn_terms(coefficients: Coefficients) -> tuple[Monomial, ...]:
    """The terms of ``J(w, n)`` as monomials in ``feed_rate_mm_min`` and ``spindle_rpm``."""
    a, b, c, q, m, yp = (getattr(coefficients, k) for k in _COEFFICIENT_KEYS)
    terms = [Monomial(a, {FEED_RATE: q / m - 1.0, SPINDLE: (1.0 - q) / m})]
    if b > 0:
        terms.append(Monomial(b, {FEED_RATE: yp - 1.0, SPINDLE: 1.0 - yp}))
    terms.append(Monomial(c, {FEED_RATE: -1.0}))
    return tuple(terms)


def evaluate(terms: Sequence[Monomial], point: Mapping[str, float]) -> float:
    """``J`` at ``point``: the sum of its terms."""
    return sum(t.evaluate(point) for t in terms)
