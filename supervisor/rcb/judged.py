"""A reading as the monitor judged it, before anything learns from it (:mod:`.update`).

:func:`judge` asks the strategy what it expects of a reading and the monitor how it judges
it; when the report shows a change every operation shares (:mod:`.common_cause`),
:meth:`Judged.rejudged` judges it again with that change, and :meth:`Judged.shifted` is the
reading an operation would have had under it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from models.quantities import MODEL_QUANTITIES
from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement, PartReport
from supervisor.inputs.plan import Operation
from supervisor.optimize.result import OperationResult
from supervisor.rcb.monitor import Watched, watch
from supervisor.rcb.monitor_state import Expected, Monitor
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.state import RcbState


@dataclass
class Judged:
    """A reading as the monitor judged it (:func:`judge`), before anything learns from it.

    ``watched`` is replaced when the report shows a common cause (:mod:`.common_cause`).
    """

    op: Operation
    made: OperationResult
    quantity: str
    measurement: Measurement
    monitor: Monitor
    watched: Watched
    point: dict[str, float] | None = None
    exponents: Mapping[str, float] | None = None
    expected: tuple[Expected, Expected | None] | None = None  # what the strategy expected

    def shifted(self, shift: float, variance: float, scale: float = 1.0) -> Measurement | None:
        """What the strategy expected on the high side, moved by a common change (None: nothing).

        ``shift`` and ``variance``: the change [ln] and its variance, which with the
        expectation's own (its readings' noise at ``scale``, at least the measured ``ŝ``)
        make the value's expanded uncertainty (``k = 2``).
        """
        if self.expected is None or self.expected[1] is None:
            return None
        high = self.expected[1]
        value = math.exp(high.mean + shift)
        noise = max(self.monitor.scale, scale) * high.noise
        spread2 = high.sd**2 + noise**2 + variance
        return Measurement(value, COVERAGE_FACTOR * value * math.sqrt(spread2))

    def rejudged(self, exponent_sd: float, common: tuple[float, float]) -> Watched:
        """The judgement when the part's operations moved together (``watch``'s ``common``)."""
        assert self.expected and self.point is not None and self.exponents is not None
        low, high = self.expected
        point, exponents = self.point, self.exponents
        measurement = self.measurement
        return watch(self.monitor, low, high, measurement, point, exponents, exponent_sd, common)


def judge(
    state: RcbState,
    op: Operation,
    made: OperationResult,
    quantity: str,
    measurement: Measurement,
    report: PartReport,
    chain: NoiseScale,
) -> Judged:
    """What the strategy expects of a reading and how the monitor judges it.

    ``chain``: the noise scale of the chain that reads ``quantity``, before the report.
    """
    monitor = state.monitors.get((op.name, quantity)) or Monitor()
    judged = Judged(op, made, quantity, measurement, monitor, Watched("accept", monitor))
    if MODEL_QUANTITIES[quantity].sense == "max":  # a tool life too good to be true is rare
        age = report.edge_parts.get(op.name)
        judged.point = {**made.setpoint, **op.context}
        judged.exponents = exponents = state.tools[op.name].models[quantity].exponents
        rule = state.settings.rule
        judged.expected = rule.expects(state, op, made, quantity, age, monitor, chain)
        low, high = judged.expected
        sd = state.settings.exponent_sd
        judged.watched = watch(monitor, low, high, measurement, judged.point, exponents, sd)
    return judged
