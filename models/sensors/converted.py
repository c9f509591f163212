"""The :class:`Converted` pair every sensor conversion returns: a value and its uncertainty."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass


@dataclass(frozen=True)
class Converted:
    """A converted value and its uncertainty (same unit; standard or expanded as the inputs).

    Unpacks as a pair: ``force_N, u_force_N = to_force(...)``.
    """

    value: float
    uncertainty: float

    def __iter__(self) -> Iterator[float]:
        """Yield ``value`` then ``uncertainty``."""
        yield self.value
        yield self.uncertainty
