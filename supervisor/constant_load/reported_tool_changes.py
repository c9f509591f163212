"""The tool changes a part report's feed overrides call for, at the setpoints it was made with.

Each reported override gives the feed the inner loop commanded; read on the setpoint the part
was made with, Tai et al.'s rule (§III.C: change the tool when the commanded feed reaches the
lower limit, :mod:`supervisor.constant_load.tool_change_rule`) says whether the edge is due,
here to within 1 ppm of the lower limit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from models.errors import InputError
from supervisor.constant_load.setpoint import ConstantLoadSetpoint

# What ``tool_changes`` reads of a part report and of the setpoints it was made with (a
# ``PartReport``, a ``PlanResult``): constant_load/ imports neither inputs/ nor optimize/, which
# import it (issue 31: no two-way folder imports).


class Overrides(Protocol):
    """A part report's feed overrides (``PartReport``)."""

    @property
    def feed_overrides(self) -> Mapping[str, float]:
        """Per operation, the feed override the control reported [%]."""
        ...


class OperationMade(Protocol):
    """One operation's setpoint as a result holds it (``OperationResult``)."""

    @property
    def name(self) -> str:
        """The operation's name."""
        ...

    @property
    def constant_load(self) -> ConstantLoadSetpoint | None:
        """Its constant-load setpoint, if it has constant-load control."""
        ...


class Made(Protocol):
    """The setpoints a part was made with (``PlanResult``)."""

    @property
    def operations(self) -> Sequence[OperationMade]:
        """Every operation's setpoint."""
        ...


@dataclass(frozen=True)
class ToolChange:
    """What a reported feed override says about an operation's edge (Tai et al. §III.C).

    Parameters
    ----------
    operation : str
        The operation.
    feed_override_percent : float
        The reported override [% of the programmed feed rate].
    commanded_feed_rate_mm_min : float
        ``programmed × override / 100`` [mm/min].
    feed_rate_lower_mm_min : float
        The lower feed limit of the setpoint the part was made with [mm/min].
    due : bool
        Change the tool: the commanded feed has fallen to the lower limit.
    reason : str
        One sentence for the operator.
    """

    operation: str
    feed_override_percent: float
    commanded_feed_rate_mm_min: float
    feed_rate_lower_mm_min: float
    due: bool
    reason: str


def tool_change(
    operation: str, setpoint: ConstantLoadSetpoint, feed_override_percent: float
) -> ToolChange:
    """Whether the feed the inner loop commands has fallen to the lower feed limit.

    Under constant load the feed falls as the edge wears (Eq. 15); at the lower limit the wear
    is in the tool-change interval and the tool is changed (Tai et al. §II.F, Tables 1-2). The
    commanded feed is the programmed feed times the override; it is due at or below the lower
    limit (within 1 ppm). Where the programmed feed is already at the lower limit
    (``tool_change_by_feed`` false) the feed says nothing about wear and no change is due.
    """
    commanded = setpoint.programmed_feed_rate_mm_min * feed_override_percent / 100.0
    lower = setpoint.feed_rate_lower_mm_min
    if not setpoint.tool_change_by_feed:
        due, reason = False, "the programmed feed is at the lower limit: change edges by count"
    elif commanded <= lower * (1.0 + 1e-6):
        due = True
        reason = (
            f"commanded feed {commanded:.1f} mm/min is at the lower limit {lower:.1f} mm/min: "
            f"flank wear is in the tool-change interval "
            f"{setpoint.wear_interval_mm[0] * 1000:g}-{setpoint.wear_interval_mm[1] * 1000:g} µm"
        )
    else:
        due = False
        reason = f"commanded feed {commanded:.1f} mm/min is above the lower limit {lower:.1f}"
    return ToolChange(operation, feed_override_percent, commanded, lower, due, reason)


def tool_changes(
    report: Overrides, made_with: Made, max_feed_rate_mm_min: float | None = None
) -> tuple[ToolChange, ...]:
    """One :class:`ToolChange` per reported feed override, in the report's order.

    ``max_feed_rate_mm_min``: the machine's (absent: none); an override that commands more
    no control can have given.

    Raises
    ------
    InputError
        An override for an operation the plan does not have, or one without constant-load
        control, or one that commands a feed above the machine's maximum; the field is named.
    """
    setpoints = {op.name: op for op in made_with.operations}
    changes = []
    for name, percent in report.feed_overrides.items():
        where = f"operations.{name}.feed_override_percent"
        if name not in setpoints:
            raise InputError(where, percent, f"{name!r} is not an operation of the plan")
        constant_load = setpoints[name].constant_load
        if constant_load is None:
            raise InputError(where, percent, f"operation {name!r} has no constant-load control")
        change = tool_change(name, constant_load, percent)
        commanded = change.commanded_feed_rate_mm_min
        if max_feed_rate_mm_min is not None and commanded > max_feed_rate_mm_min:
            raise InputError(
                where,
                percent,
                f"commands {commanded:.6g} mm/min of the programmed "
                f"{constant_load.programmed_feed_rate_mm_min:.6g}, above the machine's maximum "
                f"feed rate {max_feed_rate_mm_min:g} mm/min",
            )
        changes.append(change)
    return tuple(changes)
