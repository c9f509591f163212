"""The faults of one closed-loop scenario: what is in force at each part, and what they did.

:class:`FaultLog` draws a scenario's bends and dropout stream from its seed
(:mod:`supervisor.virtual.faults`), hands :func:`~supervisor.virtual.simulate.run_part` the
:class:`~supervisor.virtual.faults.PartFaults` of each part and tallies, per fault, what it
did (:class:`Tally`), for the certificate's rows per fault
(:mod:`supervisor.virtual.certificate`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Literal, NamedTuple

from supervisor.virtual.fault_spec import Fault, Faults
from supervisor.virtual.faults import (
    PartFaults,
    draw_bends,
    fault_rng,
    part_faults,
    readings_per_part,
)
from supervisor.virtual.machine import PartOutcome, VirtualMachine


class Tally(NamedTuple):
    """What one fault did in a scenario (or, summed or maximised, in a certificate).

    Parameters
    ----------
    fault : str
        The fault, ``KIND:ARGS``.
    what : str
        What ``value`` counts or measures.
    value : float
        The count, or the largest value seen [unit of ``what``].
    of : float
        Out of how many (a count), or the largest value possible (a maximum).
    combine : {"sum", "max"}
        How scenarios combine: counts add, maxima take the largest.
    """

    fault: str
    what: str
    value: float
    of: float
    combine: Literal["sum", "max"]


def combine(tallies: Iterable[Tally]) -> tuple[Tally, ...]:
    """Tallies of the same fault and ``what`` combined, in first-seen order."""
    out: dict[tuple[str, str], Tally] = {}
    for t in tallies:
        key = (t.fault, t.what)
        seen = out.get(key)
        if seen is None:
            out[key] = t
        elif t.combine == "sum":
            out[key] = seen._replace(value=seen.value + t.value, of=seen.of + t.of)
        else:
            out[key] = seen._replace(value=max(seen.value, t.value), of=max(seen.of, t.of))
    return tuple(out.values())


class FaultLog:
    """The faults of one scenario, part by part (a tally that grows as parts are made).

    Parameters
    ----------
    faults : Faults
        The fault set.
    machine : VirtualMachine
        The scenario's machine (its wear drift is the ``wear`` fault).
    seed : int
        The scenario's seed; every fault stream is derived from it.
    """

    def __init__(self, faults: Faults, machine: VirtualMachine, seed: int) -> None:
        self.faults = faults
        self.machine = machine
        self.bends = draw_bends(machine, seed, faults.curvature)
        self.dropout_rng = fault_rng(seed, "dropout")
        self.readings = readings_per_part(machine)
        self.parts = 0
        self.dropped = 0
        self.after_step: dict[int, int] = {p: 0 for p, _ in faults.steps}
        self.noisier = 0
        self.max_bend = 0.0
        self.max_rise = 0.0

    def for_part(self, part: int) -> PartFaults | None:
        """The faults in force at part ``part`` (1-based); None when only wear is set."""
        if not self.faults.beyond_wear:
            return None
        return part_faults(self.faults, self.bends, part, self.dropout_rng, self.readings)

    def record(
        self,
        part: int,
        setpoints: Mapping[str, Mapping[str, float]],
        outcome: PartOutcome,
        edge_parts: Mapping[str, int],
    ) -> None:
        """Tally part ``part``, made at ``setpoints`` with ``edge_parts``, and its outcome."""
        self.parts += 1
        self.dropped += len(outcome.dropped)
        for first in self.after_step:
            self.after_step[first] += part >= first
        noise_step = self.faults.noise_step
        self.noisier += noise_step is not None and part >= noise_step[0]
        drift = self.machine.wear_drift_per_edge_life
        for compiled in self.machine.compiled:
            ln_x = [math.log(setpoints[compiled.name][p]) for p in compiled.parameters]
            for bend in self.bends.get(compiled.name, {}).values():
                self.max_bend = max(self.max_bend, abs(bend.at(ln_x)))
            life = outcome.true_values[compiled.name].get("tool_life_mm3")
            if drift and life is not None:
                used = edge_parts.get(compiled.name, 0)
                self.max_rise = max(self.max_rise, drift * used * compiled.volume_mm3 / life)

    def _tally(self, fault: Fault) -> Tally:
        spec = fault.spec
        readings = float(self.parts * self.readings)
        if fault.kind == "dropout":
            return Tally(spec, "readings dropped out", float(self.dropped), readings, "sum")
        if fault.kind == "noise-scale":
            kept = readings - self.dropped
            return Tally(spec, "readings with scaled noise", kept, readings, "sum")
        if fault.kind == "step":
            made = float(self.after_step[int(fault.arguments[0])])
            return Tally(spec, "parts made with the step in force", made, self.parts, "sum")
        if fault.kind == "noise-step":
            what = "parts made with the noisier chain"
            return Tally(spec, what, float(self.noisier), self.parts, "sum")
        if fault.kind == "curvature":
            what = "max |ln bend| at the parts made / over the box"
            return Tally(spec, what, self.max_bend, fault.arguments[0], "max")
        what = "max rise reached / at end of edge life"
        return Tally(spec, what, self.max_rise, fault.arguments[0], "max")

    def tallies(self) -> tuple[Tally, ...]:
        """One tally per fault, in the order of the fault set."""
        return tuple(self._tally(f) for f in self.faults.faults)
