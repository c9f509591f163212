"""Cut a machine's observations into passes per operation and parts per part-count increment.

A :class:`Segmenter` takes the observations of one machine in the order the machine made them
(an MTConnect agent's sequence numbers, an OPC UA subscription's notifications) and keeps the
latest value of every signal. A load sample (spindle load or current) belongs to the pass of
the operation its block or tool selects (:mod:`supervisor.collect.selectors`) while the
execution state is ``ACTIVE``; samples in other states or outside every mapped operation are
not used. When the part count rises by one the part is done: each pass is reduced to one
reading, the ``percentile`` of its samples (100: the maximum, as Ivester & Heigel read the peak
of the spindle load of each pass, Fig. 5), with the median spindle speed and feed rate of the
pass, which the calibration needs (the idle load from the calibration's spindle-speed table).

A part is never reported with a reading it cannot vouch for. It is *skipped*, with the reason,
when observations were lost while it was made (an MTConnect buffer wrap, :class:`Gap`), when the
collector joined while it was being made, when the part count rose by more than one (several
parts ended without their passes being told apart), or when no pass had a sample.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from models.errors import InputError
from supervisor.collect.selectors import OperationSelector, operation_at

#: The signals a collector reads; the protocol layers name their sources in their config.
ITEMS = (
    "spindle_load",
    "spindle_speed_rpm",
    "feed_rate_mm_min",
    "block",
    "tool_number",
    "part_count",
    "execution",
    "program",
)
#: The execution state in which load samples count (MTConnect ``Execution``; OPC UA mapped).
ACTIVE = "ACTIVE"
_JOINED = "the collector joined while the part was being made"
_STATE_KEYS = (
    "part_count",
    "block",
    "tool_number",
    "execution",
    "program",
    "spindle_speed_rpm",
    "feed_rate_mm_min",
    "tainted",
)


@dataclass(frozen=True)
class Observation:
    """One value of one signal, with its place in the machine's order (``sequence``)."""

    sequence: int
    item: str
    value: float | int | str | None


@dataclass(frozen=True)
class Gap:
    """Observations ``first_lost..last_lost`` never reached the collector.

    None for ``last_lost``: the end is unknown; for both: the source numbers nothing (OPC UA).
    """

    first_lost: int | None
    last_lost: int | None
    reason: str

    def describe(self) -> str:
        """``sequences 120..344 lost (buffer wrapped)``, or the reason alone."""
        if self.first_lost is None:
            return self.reason
        end = "?" if self.last_lost is None else str(self.last_lost)
        return f"sequences {self.first_lost}..{end} lost ({self.reason})"


@dataclass(frozen=True)
class PassReading:
    """One operation's pass on one part, reduced to one reading.

    Parameters
    ----------
    operation : str
        Operation name.
    value : float
        The percentile of the pass's load samples (100: the maximum) [V or A].
    samples : int
        Load samples in the pass.
    spindle_speed_rpm : float or None
        Median spindle speed during the pass [rpm].
    feed_rate_mm_min : float or None
        Median feed rate during the pass [mm/min].
    """

    operation: str
    value: float
    samples: int
    spindle_speed_rpm: float | None
    feed_rate_mm_min: float | None


@dataclass(frozen=True)
class PartDone:
    """A part made with every observation seen: its passes, by operation in the map's order."""

    part_count: int
    program: str
    passes: tuple[PassReading, ...]
    missing: tuple[str, ...]
    last_sequence: int


@dataclass(frozen=True)
class PartSkipped:
    """Parts (by part count) that are not reported, and why."""

    part_counts: tuple[int, ...]
    program: str
    reason: str
    last_sequence: int


Outcome = PartDone | PartSkipped


def reduce_pass(loads: Sequence[float], percentile: float) -> float:
    """The ``percentile`` (0-100, linear interpolation) of a pass's samples; 100 is the maximum."""
    return float(np.percentile(np.asarray(loads, dtype=float), percentile))


class Segmenter:
    """The running segmentation of one machine's observations (see the module docstring).

    Parameters
    ----------
    selectors : Sequence[OperationSelector]
        The mapped operations, in the order the report lists them.
    percentile : float
        The pass reading: 100 (default) the maximum, e.g. 99 a robust peak.
    state : Mapping, optional
        A :meth:`snapshot` taken at a part boundary, to resume from (the collector's checkpoint).
    joined_mid_part : bool
        Without ``state``: whether a part may be in progress when observations start (its
        passes are incomplete, so it is skipped). A collector that learns the execution state
        before any load sample clears this when the machine is not ``ACTIVE``.
    """

    def __init__(
        self,
        selectors: Sequence[OperationSelector],
        *,
        percentile: float = 100.0,
        state: Mapping[str, Any] | None = None,
        joined_mid_part: bool = True,
    ) -> None:
        if not (math.isfinite(percentile) and 0 < percentile <= 100):
            raise InputError("percentile", percentile, "must be in (0, 100]")
        self.selectors = tuple(selectors)
        self.percentile = percentile
        self.values: dict[str, Any] = dict.fromkeys(_STATE_KEYS)
        if state is not None:
            unknown = sorted(set(state) - set(_STATE_KEYS))
            if unknown:
                raise InputError("state", unknown, "not segmenter state")
            self.values.update(state)
        elif joined_mid_part:
            self.values["tainted"] = _JOINED
        self._cut_seen = False
        self._loads: dict[str, list[float]] = {}
        self._speeds: dict[str, list[float]] = {}
        self._feeds: dict[str, list[float]] = {}

    def snapshot(self) -> dict[str, Any]:
        """The state to resume from after the last part boundary (JSON-serialisable)."""
        return dict(self.values)

    def gap(self, gap: Gap) -> None:
        """Observations were lost: the part being made cannot be reported."""
        self.values["tainted"] = gap.describe()

    def feed(self, observation: Observation) -> list[Outcome]:
        """Take one observation; the parts it finishes (none, one done, or skipped ones)."""
        item, value = observation.item, observation.value
        if item not in ITEMS:
            raise InputError("item", item, f"unknown; expected one of: {', '.join(ITEMS)}")
        if item == "spindle_load":
            self._sample(value)
            return []
        if item == "part_count":
            return self._part_count(value, observation.sequence)
        if item == "execution":
            self._execution(value)
        elif item == "block":
            if value is not None:  # a block without a number keeps the operation before it
                self.values["block"] = int(value)
        else:
            self.values[item] = value
        return []

    def _execution(self, value: object) -> None:
        # joined, and the machine stops before it cut anything we saw: between parts, so the
        # next part is seen whole
        if value != ACTIVE and not self._cut_seen and self.values["tainted"] == _JOINED:
            self.values["tainted"] = None
        self.values["execution"] = value

    def _sample(self, value: object) -> None:
        if not isinstance(value, int | float) or not math.isfinite(value):
            return  # UNAVAILABLE or not a number: no sample
        if self.values["execution"] != ACTIVE:
            return
        self._cut_seen = True
        operation = operation_at(self.selectors, self.values["block"], self.values["tool_number"])
        if operation is None:
            return
        self._loads.setdefault(operation, []).append(float(value))
        for key, into in (("spindle_speed_rpm", self._speeds), ("feed_rate_mm_min", self._feeds)):
            measured = self.values[key]
            if isinstance(measured, int | float) and math.isfinite(measured):
                into.setdefault(operation, []).append(float(measured))

    def _part_count(self, value: object, sequence: int) -> list[Outcome]:
        if not isinstance(value, int | float) or not math.isfinite(value):
            return []  # UNAVAILABLE: the count is unknown, not changed
        count, before = int(value), self.values["part_count"]
        program = str(self.values["program"] or "")
        self.values["part_count"] = count
        if before is None or count == before:
            return []
        outcomes: list[Outcome]
        tainted = self.values["tainted"]
        if count < before:
            reason = f"the part counter went back from {before} to {count}"
            outcomes = [PartSkipped((count,), program, reason, sequence)]
        elif tainted or count > before + 1:
            reason = tainted or (
                f"the part count jumped from {before} to {count}: passes cannot be told apart"
            )
            counts = tuple(range(before + 1, count + 1))
            outcomes = [PartSkipped(counts, program, reason, sequence)]
        else:
            outcomes = [self._done(count, program, sequence)]
        self.values["tainted"] = None
        self._loads, self._speeds, self._feeds = {}, {}, {}
        return outcomes

    def _done(self, count: int, program: str, sequence: int) -> Outcome:
        passes = []
        for s in self.selectors:
            loads = self._loads.get(s.operation)
            if not loads:
                continue
            speeds, feeds = self._speeds.get(s.operation), self._feeds.get(s.operation)
            passes.append(
                PassReading(
                    s.operation,
                    reduce_pass(loads, self.percentile),
                    len(loads),
                    float(statistics.median(speeds)) if speeds else None,
                    float(statistics.median(feeds)) if feeds else None,
                )
            )
        if not passes:
            reason = "no load sample in a mapped operation while ACTIVE"
            return PartSkipped((count,), program, reason, sequence)
        missing = tuple(s.operation for s in self.selectors if s.operation not in self._loads)
        return PartDone(count, program, tuple(passes), missing, sequence)
