"""The registry of constrained quantities: one entry per quantity, all that the supervisor needs.

Names carry their unit (DESIGN.md, "Contracts"). A ``max`` quantity has an allowable maximum
(force, roughness, power ...); a ``min`` quantity an allowable minimum (tool life).

A quantity is either a *model* quantity, predicted by a tool's empirical power law
``Y = K · Π x_i^e_i`` (Ivester & Heigel Eqs. 5, 6, 8), or *derived*: a monomial ``factor`` in
the cutting parameters and the operation's context, times the model quantity it is ``based_on``
when there is one (power ``F·v/60000`` and torque ``F·D/2000`` from the force, Ivester Eq. 3),
or on its own (spindle speed, feed rate: exact kinematics, band 0). Every consumer derives what
it needs from :data:`QUANTITIES`: the optimiser's rows (:mod:`supervisor.optimize.formulation`),
the predictions (:func:`models.tool.predict_all`), the virtual machine's true values
(:mod:`supervisor.virtual.simulate`), the plan's limits and machine fields
(:mod:`supervisor.inputs.plan`) and the labels of plots and tables. A new quantity is one
:func:`register` call (or one line below); a name the registry does not hold is an
:class:`UnknownQuantityError`, never a guess.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Literal

from models import kinematics
from models.errors import InputError
from models.kinematics import Process
from models.monomial import Monomial

Sense = Literal["max", "min"]
#: ``model``: a tool's power law predicts it; ``derived``: it follows from the parameters.
Kind = Literal["model", "derived"]

#: The tool-life limit: parts one edge must make before ``allowable_flank_wear_mm``; the plan
#: gives it, and the optimiser bounds ``tool_life_mm3 >= parts_per_edge · volume_mm3``.
PARTS_PER_EDGE = "parts_per_edge"


class UnknownQuantityError(InputError):
    """A quantity (or limit) name the registry does not hold, or used against its kind."""


@dataclass(frozen=True)
class Quantity:
    """A constrained or predicted quantity.

    Parameters
    ----------
    name : str
        Field name with its unit, e.g. ``force_N``.
    unit : str
        Unit as printed in tables.
    sense : {"max", "min"}
        Whether a limit on it is a maximum or a minimum.
    description : str
        One line for tables and errors.
    label : str
        Short name for plot axes and table headers, e.g. ``torque``.
    kind : {"model", "derived"}
        Predicted by a tool's model, or derived from the cutting parameters.
    machine_field : str or None
        The machine limit that bounds it, as a plan file's ``[machine]`` table and the REST
        ``MachineIn`` name it (``max_torque_Nm``), or None. Everything else about a machine
        limit is derived from this: :class:`supervisor.inputs.plan.Machine` holds its value
        keyed by :attr:`name`, the database's ``machines.limits`` likewise, the REST schema and
        the read side by this name.
    factor : Callable[[Process], Monomial] or None
        Derived: the monomial in the cutting parameters and the context that multiplies
        :attr:`based_on` (or is the value, without one) [unit per unit of ``based_on``].
    based_on : str or None
        Derived: the model quantity it scales, whose band edge it inherits (``force_N``).
    limit_key : str or None
        The key of its limit in a plan's ``limits`` (default: :attr:`name`).
    limit_per_volume : bool
        The limit is given per part: the bound is ``limit · volume_mm3`` (tool life).
    drifts_with_wear : bool
        Its true value rises as the edge wears (the virtual machine's wear drift).
    """

    name: str
    unit: str
    sense: Sense
    description: str
    label: str
    kind: Kind = "model"
    machine_field: str | None = None
    factor: Callable[[Process], Monomial] | None = None
    based_on: str | None = None
    limit_key: str | None = None
    limit_per_volume: bool = False
    drifts_with_wear: bool = False

    @property
    def limit_name(self) -> str:
        """The key of its limit in a plan's ``limits``."""
        return self.limit_key or self.name

    def factor_of(self, process: Process) -> Monomial:
        """The monomial :attr:`factor` of ``process``; a model quantity has none (an error)."""
        if self.factor is None:
            raise UnknownQuantityError(self.name, self.kind, "a model quantity has no factor")
        return self.factor(process)

    def monomial(self, process: Process, base: Monomial | None = None) -> Monomial:
        """A derived quantity as a monomial: ``base · factor`` (``base``: the edge it scales).

        Raises
        ------
        UnknownQuantityError
            A model quantity (its monomial is the tool's model), or ``base`` missing or given
            against :attr:`based_on`.
        """
        factor = self.factor_of(process)
        if self.based_on is None:
            if base is not None:
                raise UnknownQuantityError(self.name, "base", "derived from no model")
            return factor
        if base is None:
            raise UnknownQuantityError(self.name, None, f"needs the {self.based_on} edge")
        return base * factor


def _power_per_newton(process: Process) -> Monomial:
    """``v / 60000`` [kW/N] (Sandvik Coromant, ``Pc = Fc·vc/60000``)."""
    return kinematics.power_per_newton_monomial()


#: Every quantity by name, in a stable order: the model quantities, then the derived ones.
QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        Quantity("force_N", "N", "max", "cutting force", "force F", drifts_with_wear=True),
        Quantity(
            "roughness_um", "µm", "max", "surface roughness Ra", "roughness Ra",
            drifts_with_wear=True,
        ),
        Quantity(
            "tool_life_mm3", "mm³", "min", "volume one edge removes before the wear limit",
            "tool life", limit_key=PARTS_PER_EDGE, limit_per_volume=True,
        ),
        Quantity(
            "spindle_current_A", "A", "max", "spindle motor current", "spindle current",
            drifts_with_wear=True,
        ),
        Quantity(
            "power_kW", "kW", "max", "cutting power at the upper force band", "power",
            "derived", "max_power_kW", _power_per_newton, "force_N",
        ),
        Quantity(
            "torque_Nm", "N·m", "max", "spindle torque at the upper force band", "torque",
            "derived", "max_torque_Nm", kinematics.torque_per_newton_monomial, "force_N",
        ),
        Quantity(
            "spindle_rpm", "rpm", "max", "spindle speed", "spindle speed",
            "derived", "max_spindle_rpm", kinematics.spindle_rpm_monomial,
        ),
        Quantity(
            "feed_rate_mm_min", "mm/min", "max", "feed rate", "feed rate",
            "derived", "max_feed_rate_mm_min", kinematics.feed_rate_monomial,
        ),
    )
}  # fmt: skip


class _View(Mapping[str, Quantity]):
    """The quantities of one kind, read live from :data:`QUANTITIES` in its order."""

    def __init__(self, kind: Kind) -> None:
        self._kind = kind

    def __getitem__(self, name: str) -> Quantity:
        quantity = QUANTITIES[name]
        if quantity.kind != self._kind:
            raise KeyError(name)
        return quantity

    def __iter__(self) -> Iterator[str]:
        return (n for n, q in QUANTITIES.items() if q.kind == self._kind)

    def __len__(self) -> int:
        return sum(1 for q in QUANTITIES.values() if q.kind == self._kind)

    def __repr__(self) -> str:
        return f"{self._kind} quantities: {', '.join(self)}"


#: Quantities an empirical power-law model may predict (Ivester & Heigel Eqs. 5, 6, 8).
MODEL_QUANTITIES: Mapping[str, Quantity] = _View("model")
#: Quantities derived from the cutting parameters and the force model (machine limits).
DERIVED_QUANTITIES: Mapping[str, Quantity] = _View("derived")


def quantity(name: str) -> Quantity:
    """The registered quantity ``name``; unknown names raise :class:`UnknownQuantityError`."""
    found = QUANTITIES.get(name)
    if found is None:
        raise UnknownQuantityError(name, name, f"unknown quantity; known: {', '.join(QUANTITIES)}")
    return found


def limit_keys() -> tuple[str, ...]:
    """The keys a plan's ``limits`` may hold: the maxima by name, then the per-part limits."""
    own = [q.limit_name for q in QUANTITIES.values() if q.limit_key is None]
    return (*own, *(q.limit_name for q in QUANTITIES.values() if q.limit_key is not None))


def limited_by(key: str) -> Quantity:
    """The quantity a plan's limit ``key`` bounds (``parts_per_edge``: ``tool_life_mm3``)."""
    for q in QUANTITIES.values():
        if q.limit_name == key:
            return q
    raise UnknownQuantityError(key, key, f"unknown limit; known: {', '.join(limit_keys())}")


def machine_fields() -> dict[str, str]:
    """Per machine field (``max_torque_Nm``), the quantity it bounds (``torque_Nm``)."""
    return {q.machine_field: q.name for q in QUANTITIES.values() if q.machine_field is not None}


def register(new: Quantity) -> None:
    """Add ``new`` to :data:`QUANTITIES` after checking that it fits the registry.

    Raises
    ------
    InputError
        The name (or limit key, or machine field) is taken, a derived quantity has no
        ``factor``, or it is based on something that is not a model quantity.
    """
    if new.name in QUANTITIES:
        raise InputError("quantity.name", new.name, "already registered")
    if new.limit_name in limit_keys():
        raise InputError("quantity.limit_key", new.limit_name, "already a limit key")
    if new.machine_field is not None and new.machine_field in machine_fields():
        raise InputError("quantity.machine_field", new.machine_field, "already bounds another")
    if new.kind == "derived" and new.factor is None:
        raise InputError(f"{new.name}.factor", None, "a derived quantity needs a factor")
    if new.kind == "model" and (new.factor is not None or new.based_on is not None):
        raise InputError(f"{new.name}.factor", new.factor, "a model quantity has its model")
    if new.based_on is not None and new.based_on not in MODEL_QUANTITIES:
        raise InputError(f"{new.name}.based_on", new.based_on, "not a model quantity")
    QUANTITIES[new.name] = new
