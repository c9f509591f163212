"""The fault catalogue of the virtual shop floor: what each fault is, and reading ``KIND:ARGS``.

A fault is written ``KIND`` (the catalogue default) or ``KIND:ARGS`` (``--fault dropout:0.1``);
every kind, its arguments, their checks and its default are declared once in :data:`KINDS`,
and the CLI help, the errors and the docs are derived from it. What a fault does to a part is
:mod:`supervisor.virtual.faults`; its oracle :mod:`supervisor.virtual.fault_oracle`.

This module imports nothing heavy (no NumPy): ``rcb certify --help`` reads it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from models.errors import InputError

#: The flag a fault is given with (the name errors carry when no other is given).
FLAG = "--fault"


@dataclass(frozen=True)
class Argument:
    """One argument of a fault kind: its name, whether it is an integer, and its check."""

    name: str
    integer: bool
    ok: Callable[[float], bool]
    requirement: str


def _positive(x: float) -> bool:
    return x > 0


def _at_least_zero(x: float) -> bool:
    return x >= 0


def _probability(x: float) -> bool:
    return 0 <= x <= 1


def _part(x: float) -> bool:
    return x >= 1


@dataclass(frozen=True)
class Kind:
    """A kind of fault: its arguments, its default and what it does (one line)."""

    name: str
    arguments: tuple[Argument, ...]
    default: tuple[float, ...]
    does: str


#: The part a fault starts at (``step``, ``noise-step``).
FROM_PART = Argument("PART", True, _part, "a part number >= 1")

#: The catalogue, in the order the faults are applied and listed. The RNG stream of a fault
#: that draws is ``numpy.random.default_rng([seed, 1 + its index here])``.
KINDS: dict[str, Kind] = {
    k.name: k
    for k in (
        Kind(
            "dropout",
            (Argument("P", False, _probability, "a probability in [0, 1]"),),
            (0.03,),
            "each reading, with probability P, comes in at U(0.05, 0.30) of its true value",
        ),
        Kind(
            "noise-scale",
            (Argument("S", False, _positive, "a number > 0"),),
            (3.0,),
            "the true measurement noise is S times what the reported u says",
        ),
        Kind(
            "step",
            (
                FROM_PART,
                Argument("FACTOR", False, _positive, "a number > 0"),
            ),
            (15.0, 1.12),
            "from part PART on, every true force, roughness and current is x FACTOR",
        ),
        Kind(
            "curvature",
            (Argument("C", False, _at_least_zero, "a number >= 0"),),
            (0.06,),
            "ln of every true model bends by up to C over the bounds box (not a power law)",
        ),
        Kind(
            "wear",
            (Argument("D", False, _at_least_zero, "a number >= 0"),),
            (0.05,),
            "force, roughness and current rise by D over an edge's life (--wear-drift D)",
        ),
        Kind(
            "noise-step",
            (
                FROM_PART,
                Argument("S", False, _positive, "a number > 0"),
            ),
            (500.0, 3.0),
            "from part PART on, the true measurement noise is S times more (a chain degrades)",
        ),
    )
}


@dataclass(frozen=True)
class Fault:
    """One fault: its kind (a key of :data:`KINDS`) and its arguments in the kind's order."""

    kind: str
    arguments: tuple[float, ...]

    @property
    def spec(self) -> str:
        """``KIND:ARG[:ARG]`` with every argument written out (``step:15:1.12``)."""
        kind = KINDS[self.kind]
        parts = [
            str(int(v)) if a.integer else f"{v:g}"
            for a, v in zip(kind.arguments, self.arguments, strict=True)
        ]
        return ":".join([self.kind, *parts])


@dataclass(frozen=True)
class Faults:
    """A set of faults, in the order given; at most one of each kind but ``step``.

    Parameters
    ----------
    faults : tuple[Fault, ...]
        The faults; ``Faults()`` is the fault-free shop floor.
    """

    faults: tuple[Fault, ...] = ()

    def __post_init__(self) -> None:
        seen: set[str] = set()
        steps: set[float] = set()
        for fault in self.faults:
            if fault.kind not in KINDS:
                raise InputError(FLAG, fault.kind, f"unknown fault; expected one of: {_names()}")
            if fault.kind == "step":
                if fault.arguments[0] in steps:
                    raise InputError(FLAG, fault.spec, "a second step at the same part")
                steps.add(fault.arguments[0])
            elif fault.kind in seen:
                raise InputError(FLAG, fault.spec, f"{fault.kind} given twice (only step repeats)")
            seen.add(fault.kind)

    def __bool__(self) -> bool:
        return bool(self.faults)

    @property
    def specs(self) -> tuple[str, ...]:
        """Every fault as ``KIND:ARGS``, in order."""
        return tuple(f.spec for f in self.faults)

    def value(self, kind: str, default: float) -> float:
        """The (first) argument of the fault of ``kind``, ``default`` when there is none."""
        return next((f.arguments[0] for f in self.faults if f.kind == kind), default)

    @property
    def dropout(self) -> float:
        """Probability that a reading drops out [-]."""
        return self.value("dropout", 0.0)

    @property
    def noise_scale(self) -> float:
        """True noise over the noise the reported u says [-]."""
        return self.value("noise-scale", 1.0)

    @property
    def curvature(self) -> float:
        """Largest bend of ``ln y`` over the bounds box [-]."""
        return self.value("curvature", 0.0)

    @property
    def wear(self) -> float:
        """Rise of force, roughness and current over an edge's life [-]."""
        return self.value("wear", 0.0)

    @property
    def noise_step(self) -> tuple[int, float] | None:
        """``(PART, S)`` of the noise step, None without one."""
        found = next((f.arguments for f in self.faults if f.kind == "noise-step"), None)
        return None if found is None else (int(found[0]), found[1])

    def noise_scale_at(self, part: int) -> float:
        """True noise over the noise the reported u says at part ``part`` (1-based) [-]."""
        step = self.noise_step
        more = step[1] if step is not None and part >= step[0] else 1.0
        return self.noise_scale * more

    @property
    def steps(self) -> tuple[tuple[int, float], ...]:
        """``(PART, FACTOR)`` of every step, by part."""
        return tuple(
            sorted((int(f.arguments[0]), f.arguments[1]) for f in self.faults if f.kind == "step")
        )

    @property
    def beyond_wear(self) -> bool:
        """Whether a fault other than wear is set (wear alone is today's ``--wear-drift``)."""
        return any(f.kind != "wear" for f in self.faults)


def _names() -> str:
    return ", ".join(KINDS)


def usage(kind: Kind) -> str:
    """``step:PART:FACTOR``: how a kind is written with its arguments."""
    return ":".join([kind.name, *(a.name for a in kind.arguments)])


def catalogue_help() -> str:
    """One line per kind: how it is written, its default and what it does (for ``--help``)."""
    lines = []
    for kind in KINDS.values():
        default = Fault(kind.name, kind.default).spec
        lines.append(f"{usage(kind)} ({kind.name} alone: {default}): {kind.does}")
    return "; ".join(lines)


def parse_fault(text: str, flag: str = FLAG) -> Fault:
    """Read one fault, ``KIND`` or ``KIND:ARGS``, strictly.

    Parameters
    ----------
    text : str
        The fault as given (``dropout``, ``dropout:0.1``, ``step:15:1.12``).
    flag : str
        The flag or field it came with, for the error.

    Returns
    -------
    Fault
        The fault, with the kind's default when no argument is given.

    Raises
    ------
    InputError
        An unknown kind, a wrong number of arguments, or an argument that is not a number or
        out of its range, naming ``flag`` and ``text``.
    """
    kind_name, *raw = text.strip().split(":")
    kind = KINDS.get(kind_name)
    if kind is None:
        raise InputError(flag, text, f"unknown fault; expected one of: {_names()}")
    if not raw:
        return Fault(kind.name, kind.default)
    if len(raw) != len(kind.arguments):
        raise InputError(flag, text, f"expected {kind.name} or {usage(kind)}")
    values = []
    for argument, word in zip(kind.arguments, raw, strict=True):
        try:
            value = float(int(word)) if argument.integer else float(word)
        except ValueError:
            kind_of = "an integer" if argument.integer else "a number"
            raise InputError(flag, text, f"{argument.name} must be {kind_of}") from None
        if not (math.isfinite(value) and argument.ok(value)):
            raise InputError(flag, text, f"{argument.name} must be {argument.requirement}")
        values.append(value)
    return Fault(kind.name, tuple(values))


def parse_faults(
    texts: Iterable[str], *, wear_drift: float = 0.0, flag: str = FLAG, wear_flag: str = ""
) -> Faults:
    """Read every ``--fault`` given, with ``--wear-drift D`` as the alias of ``wear:D``.

    Parameters
    ----------
    texts : Iterable[str]
        The faults as given, in order.
    wear_drift : float
        ``--wear-drift``; a value > 0 adds ``wear:D`` (an error beside a ``wear`` fault).
    flag, wear_flag : str
        The flags, for the errors (``wear_flag`` defaults to ``wear_drift_per_edge_life``).

    Returns
    -------
    Faults
        The set; ``Faults()`` when nothing is given.
    """
    faults = [parse_fault(t, flag) for t in texts]
    where = wear_flag or "wear_drift_per_edge_life"
    if not (math.isfinite(wear_drift) and wear_drift >= 0):
        raise InputError(where, wear_drift, "must be a number >= 0")
    if wear_drift > 0:
        if any(f.kind == "wear" for f in faults):
            raise InputError(where, wear_drift, f"give {flag} wear:D or {where}, not both")
        faults.append(Fault("wear", (float(wear_drift),)))
    return Faults(tuple(faults))


def with_wear(faults: Faults, wear_drift: float, flag: str = "wear_drift_per_edge_life") -> Faults:
    """``faults`` with ``wear_drift`` as ``wear:D`` (the library's alias; see parse_faults)."""
    if not (math.isfinite(wear_drift) and wear_drift >= 0):
        raise InputError(flag, wear_drift, "must be a number >= 0")
    if wear_drift == 0:
        return faults
    if faults.wear and faults.wear != wear_drift:
        raise InputError(flag, wear_drift, f"differs from the fault wear:{faults.wear:g}")
    if faults.wear:
        return faults
    return Faults((*faults.faults, Fault("wear", (float(wear_drift),))))
