"""Exceptions raised by the supervisor package."""

from __future__ import annotations

from dataclasses import dataclass

from models.errors import InputError


class SupervisorError(Exception):
    """Base class of every error raised by :mod:`supervisor`."""


class PlanError(SupervisorError, InputError):
    """A plan is inconsistent: a field names something that does not fit the rest."""


class SolverError(SupervisorError, RuntimeError):
    """The solver returned no trustworthy optimum (status not optimal, or re-check failed)."""


@dataclass(frozen=True)
class Conflict:
    """A limit that cannot be met, and what it would have to be.

    Parameters
    ----------
    name : str
        Quantity name (``force_N``, ``tool_life_mm3``, ``power_kW`` ...).
    limit : float
        The limit as given, in the quantity's unit.
    required : float
        The least demanding limit that the other limits and the bounds allow.
    sense : {"max", "min"}
        Whether the limit is a maximum or a minimum.
    """

    name: str
    limit: float
    required: float
    sense: str

    def describe(self) -> str:
        """One phrase: ``force_N <= 100 needs >= 512.3``."""
        if self.sense == "max":
            return f"{self.name} <= {self.limit:.6g} needs a limit of at least {self.required:.4g}"
        return f"{self.name} >= {self.limit:.6g} can reach at most {self.required:.4g}"


class InfeasibleError(SupervisorError):
    """No cutting parameters meet every limit at the band edge within the bounds.

    Parameters
    ----------
    operation : str
        Name of the operation.
    conflicts : tuple[Conflict, ...]
        The limits that would have to move, and by how much.
    against : tuple[str, ...]
        The other limits and parameter bounds that are tight at the closest point.
    """

    def __init__(
        self, operation: str, conflicts: tuple[Conflict, ...], against: tuple[str, ...]
    ) -> None:
        self.operation = operation
        self.conflicts = conflicts
        self.against = against
        text = "; ".join(c.describe() for c in conflicts)
        tail = f" (held by {', '.join(against)})" if against else ""
        super().__init__(
            f"operation {operation!r}: limits cannot all be met at the band edge: {text}{tail}"
        )
