"""Raw spindle readings in a part report → ``force_N`` measurements, before RCB.

A report may give an operation's force as the machine measures it: the spindle load signal
(Ivester & Heigel Eqs. 1-4) or the spindle current (Kim & Jeon §6.2.3). The machine's named
calibration (``[machine.calibrations.NAME]`` in the plan) converts it with its propagated
uncertainty (:func:`models.sensors.to_force`); RCB then treats it exactly as a force
measured with that uncertainty. What the conversion needs and the reading does not carry
comes from the operation and from the setpoint the part was made with: the workpiece
diameter, the spindle speed ``n = 1000·v/(π·D)`` and the feed rate ``f·n`` (turning).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, Protocol

from models import kinematics
from models.bounds import SMALLEST_MEASURED
from models.errors import InputError
from models.sensors import Calibration, calibration_to_mapping, to_force
from models.sensors.convert import converts
from supervisor.inputs.part_report import Measurement, PartReport, Signal
from supervisor.inputs.plan import Plan

#: Stored beside a converted measurement: the reading, the calibration and the context used.
RawRecord = dict[str, Any]


class OperationSetpoint(Protocol):
    """One operation's setpoint as a result holds it (``OperationResult``)."""

    @property
    def name(self) -> str:
        """The operation's name."""
        ...

    @property
    def setpoint(self) -> Mapping[str, float]:
        """Its cutting parameters [units as named]."""
        ...


class MadeWith(Protocol):
    """The setpoints a part was made with (a ``PlanResult``; ``inputs`` does not import it)."""

    @property
    def operations(self) -> Sequence[OperationSetpoint]:
        """Every operation's setpoint."""
        ...


def resolve(
    report: PartReport, plan: Plan, made_with: MadeWith
) -> tuple[PartReport, dict[tuple[str, str], RawRecord]]:
    """Convert every raw reading of ``report``; the report RCB sees, and the raw records.

    Parameters
    ----------
    report : PartReport
        As read from the MES, with ``signals``.
    plan : Plan
        The plan (its machine's calibrations, the operations' tools and context).
    made_with : MadeWith
        The setpoints the part was made with (speed and feed for the conversion).

    Returns
    -------
    tuple[PartReport, dict[tuple[str, str], RawRecord]]
        The report with each reading replaced by its ``force_N`` measurement, and per
        ``(operation, "force_N")`` what it was converted from.

    Raises
    ------
    InputError
        Unknown operation or calibration, no calibration for the quantity, a force reported
        twice (directly and as a reading), or what the conversion refuses; the field is named.
    """
    report = _bare_currents_as_readings(report, plan)
    if not report.signals:
        return report, {}
    operations = {op.name: op for op in plan.operations}
    setpoints = {op.name: op for op in made_with.operations}
    measurements = {name: dict(m) for name, m in report.measurements.items()}
    raw: dict[tuple[str, str], RawRecord] = {}
    for name, readings in report.signals.items():
        if name not in operations:
            raise InputError(f"operations.{name}", name, f"not an operation of {plan.name!r}")
        op, tool = operations[name], plan.tools[operations[name].tool]
        for quantity, signal in readings.items():
            path = f"operations.{name}.measurements.{quantity}"
            if signal.calibration is None and quantity in tool.models and not signal.context:
                measurements.setdefault(name, {})[quantity] = signal.reading  # a model quantity
                continue
            if "force_N" in measurements.get(name, {}):
                raise InputError(path, signal.reading.value, "force_N is reported too; give one")
            label, calibration = _calibration(plan, signal, path)
            context = operating_point(op.process, {**op.context, **setpoints[name].setpoint})
            context.update(signal.context)
            force, record = _converted(quantity, signal, label, calibration, context, path)
            measurements.setdefault(name, {})["force_N"] = force
            raw[(name, "force_N")] = record
    return replace(report, measurements=measurements, signals={}), raw


def _converted(
    quantity: str,
    signal: Signal,
    label: str,
    calibration: Calibration,
    context: dict[str, object],
    path: str,
) -> tuple[Measurement, RawRecord]:
    """One reading as a ``force_N`` measurement, and the record of what it was converted from.

    The force must be a measurement as a reported one is (``>= 1e-9`` and above its
    uncertainty): a load at the idle load converted to 0 N, which the band law took as a
    reading far under the band and shrank it on (``ivester``: the setpoints rose).
    """
    force = to_force(
        calibration,
        quantity,
        signal.reading.value,
        signal.reading.uncertainty,
        context,
        path=path,
    )
    if not (force.value >= SMALLEST_MEASURED and force.uncertainty < force.value):
        raise InputError(
            f"{path}.value",
            signal.reading.value,
            f"converts to a force of {force.value:.4g} ± {force.uncertainty:.4g} N, no"
            " measurement of a cut (a force is > 0 and above its uncertainty): a load at idle,"
            " an air cut or a sensor to check",
        )
    record: RawRecord = {
        "quantity": quantity,
        "value": signal.reading.value,
        "uncertainty": signal.reading.uncertainty,
        "calibration": label,
        "calibration_table": calibration_to_mapping(calibration),
        "context": {k: v for k, v in context.items() if isinstance(v, int | float)},
    }
    return Measurement(force.value, force.uncertainty), record


def _bare_currents_as_readings(report: PartReport, plan: Plan) -> PartReport:
    """A bare ``spindle_current_A`` is a reading to convert where the tool does not model it.

    Given as ``{value, uncertainty}`` it is a measurement of the tool's spindle-current model
    (Tai et al. Eq. 14) when the operation's tool has one, and otherwise the force sensor's
    reading (Kim & Jeon §6.2.3) for the machine's calibration to convert.
    """
    tools = {op.name: plan.tools[op.tool] for op in plan.operations}
    moved: dict[str, dict[str, Measurement]] = {}
    for name, measured in report.measurements.items():
        tool = tools.get(name)
        if tool is not None and "spindle_current_A" in measured:
            if "spindle_current_A" not in tool.models:
                moved[name] = {"spindle_current_A": measured["spindle_current_A"]}
    if not moved:
        return report
    measurements = {
        name: {q: m for q, m in measured.items() if q not in moved.get(name, {})}
        for name, measured in report.measurements.items()
    }
    signals = {name: dict(s) for name, s in report.signals.items()}
    for name, readings in moved.items():
        for quantity, reading in readings.items():
            signals.setdefault(name, {})[quantity] = Signal(quantity, reading)
    return replace(report, measurements=measurements, signals=signals)


def _calibration(plan: Plan, signal: Signal, path: str) -> tuple[str, Calibration]:
    calibrations = plan.machine.calibrations
    if signal.calibration is not None:
        if signal.calibration not in calibrations:
            known = ", ".join(sorted(calibrations)) or "none"
            raise InputError(
                f"{path}.calibration",
                signal.calibration,
                f"machine {plan.machine.name!r} has no such calibration; known: {known}",
            )
        return signal.calibration, calibrations[signal.calibration]
    fitting = [(k, c) for k, c in calibrations.items() if converts(c) == signal.quantity]
    if len(fitting) != 1:
        reason = (
            f"machine {plan.machine.name!r} has no calibration converting it to force_N"
            if not fitting
            else f"machine {plan.machine.name!r} has several calibrations for it "
            f"({', '.join(k for k, _ in fitting)}): name one with 'calibration'"
        )
        raise InputError(path, signal.reading.value, reason)
    return fitting[0]


def operating_point(process: kinematics.Process, point: Mapping[str, float]) -> dict[str, object]:
    """Workpiece diameter, spindle speed and feed rate at the setpoint, where they follow."""
    context: dict[str, object] = dict(point)
    if kinematics.DIAMETER[process] in point:
        context["spindle_speed_rpm"] = kinematics.spindle_rpm_monomial(process).evaluate(point)
        if process == "turning" or "flute_count" in point:
            rate = kinematics.feed_rate_monomial(process).evaluate(point)
            context["feed_rate_mm_min"] = rate
    return context
