"""What the fleet left out of a tool's plans: counted where a new plan's prior is made.

Its own module, free of NumPy, so that the CLI's words for it (:mod:`api.report.provenance`)
load with ``rcb --help``. :mod:`db.fleet_left_out` counts them.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LeftOut:
    """A tool's plans the fleet left out, among its machines' newest: each by its first reason.

    What a prior from the rest does not hold: a plan an engineer took out (or its machine),
    one halted, one whose process changed beyond what an engineer accepted. ``rcb fleet show
    TOOL`` lists them and why, so the engineer can put one back or widen the tool's band.
    """

    taken_out: int = 0
    halted: int = 0
    changed: int = 0

    @property
    def total(self) -> int:
        """How many plans were left out."""
        return self.taken_out + self.halted + self.changed

    def counted(self) -> str:
        """``3 plans (2 halted, 1 taken out)`` ("" where none was left out)."""
        return f"{self._plans()} ({self._reasons()})" if self.total else ""

    def describe(self) -> str:
        """``3 plans of its tool left out (2 halted, 1 taken out)`` ("" where none was)."""
        return f"{self._plans()} of its tool left out ({self._reasons()})" if self.total else ""

    def _plans(self) -> str:
        return f"{self.total} {'plan' if self.total == 1 else 'plans'}"

    def _reasons(self) -> str:
        counts = [(self.halted, "halted"), (self.taken_out, "taken out"), (self.changed, "changed")]
        return ", ".join(f"{n} {why}" for n, why in counts if n)
