"""Borangiu's (w, n) problem for one pass of fixed depth and width, read from a domain file.

A domain file (:func:`load_domain_problem`; TOML: ``name``, ``[cut]``, ``[domain]``,
``[productivity]``) poses Borangiu's own problem in ``ln(w, n)``: the largest feed rate (an LP:
the largest MRR) and the least ``J`` (a GP), on the domain of Eqs. 2-7
(:mod:`models.borangiu_domain`) with the cost of :mod:`models.borangiu_cost`.

References
----------
.. [1] Borangiu et al., Embedded numeric-adaptive machining control based on data fusion,
   IFAC 2007, Eqs. 2-7, 9-12, Figs. 6-7.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from models import fields as checked
from models.borangiu_cost import (
    Coefficients,
    CostData,
    coefficients_from_cost,
    productivity_from_mapping,
)
from models.borangiu_domain import Domain, domain_from_mapping
from models.errors import InputError
from supervisor.inputs.files import read_toml


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
