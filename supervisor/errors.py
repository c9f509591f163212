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
        """One phrase: ``force_N <= 100 needs a limit of at least 512.3``."""
        needs = "needs a limit of at least" if self.sense == "max" else "can reach at most"
        sign = "<=" if self.sense == "max" else ">="
        limit, required = self.texts()
        return f"{self.name} {sign} {limit} {needs} {required}"

    def texts(self) -> tuple[str, str]:
        """The limit (6 significant digits) and what it needs (4), shown.

        Each takes more digits where the number needed would not read beyond the limit: a
        maximum of 127.303 that needs 127.30312 is not said to need "at least 127.3" (seen
        where the program was infeasible only just).
        """
        for digits in range(4, 18):
            limit = f"{self.limit:.{max(6, digits)}g}"
            required = f"{self.required:.{digits}g}"
            if (
                float(required) > float(limit)
                if self.sense == "max"
                else float(required) < float(limit)
            ):
                return limit, required
        return repr(self.limit), repr(self.required)


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
