r"""What a Monte Carlo certificate holds: its scenarios, their summary, and its digest.

The scenarios are run by :mod:`supervisor.virtual.certify`. Row ``k`` of a scenario is "after
k parts": the setpoints in force after ``k`` part reports (``k = 0``: the robust start,
``k = K``: the final setpoints). MRR/oracle of the plan is ``oracle cycle time / cycle time``
(the time-weighted MRR ratio); per operation it is ``MRR / oracle MRR``.

The certificate bounds the probability ``p`` that a part crosses at least one true limit by
the one-sided Clopper-Pearson upper limit [1]_ for ``x`` violating parts in ``n`` parts made,

.. math::

    p_\mathrm{up} = B^{-1}(1 - \alpha;\ x + 1,\ n - x), \qquad
    p_\mathrm{up} = 1 - \alpha^{1/n} \text{ for } x = 0,

with ``1 − α = 0.95`` and ``B⁻¹`` the quantile of the beta distribution. It treats parts as
independent trials; the parts of one scenario share a true process, so read it as the bound
for a shop whose machines are drawn as the scenarios are.

A violation at a scenario's first part, or at the first part made with a step fault in force,
is *unavoidable* (no controller could know the truth before it); the summary bounds the
*avoidable* ones the same way, ``x`` the violating parts and ``n`` the parts made at the other
positions (:mod:`supervisor.virtual.faults`).

References
----------
.. [1] Clopper & Pearson (1934), "The use of confidence or fiducial limits illustrated in the
   case of the binomial", Biometrika 26(4), 404-413.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from supervisor.virtual.bound import CONFIDENCE, clopper_pearson_upper
from supervisor.virtual.fault_log import Tally, combine
from supervisor.virtual.fault_spec import Faults

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Rows of a :class:`CertificateSummary`, "after k parts"; those above ``parts`` are left out
#: and ``parts`` itself is always a row.
SUMMARY_ROWS: tuple[int, ...] = (1, 5, 10)
#: The low percentile of MRR/oracle over scenarios [%].
PERCENTILE = 5.0


@dataclass(frozen=True, eq=False)
class ScenarioTrace:
    """One scenario of one strategy: rows ``0..parts``, parts ``1..parts``.

    Parameters
    ----------
    seed : int
        The scenario's seed (true process and measurement noise).
    oracle_cycle_min : float
        Cycle time of the oracle's setpoints [min].
    plan_ratio : numpy.ndarray
        ``(parts + 1,)``: oracle cycle time / cycle time of the setpoints in force after ``k``
        parts; 0 from the part that stopped the scenario on [-].
    op_ratio : numpy.ndarray
        ``(parts + 1, operations)``: per operation MRR / oracle MRR; 0 once stopped [-].
    cycle_min : numpy.ndarray
        ``(parts + 1,)``: cycle time of the setpoints in force after ``k`` parts; NaN once
        stopped [min].
    violations : numpy.ndarray
        ``(parts,)``: true limits crossed by part ``1..parts`` (0 for parts not made).
    where : tuple[tuple[int, str, str], ...]
        ``(part, operation, limit)`` of every violation, in order.
    stopped_at : int
        The part whose report left no safe setpoint; 0 if the scenario never stopped.
    stopped_op : str
        The operation that had no safe setpoint ("" if none).
    parts_made : int
        Parts made (``stopped_at`` if stopped, else ``parts``).
    unavoidable_at : tuple[int, ...]
        The parts whose violations are unavoidable: part 1 (no controller knows the truth
        before it) and the first part of each step (:func:`supervisor.virtual.faults.
        unavoidable_parts`); every other violation is avoidable.
    tallies : tuple[Tally, ...]
        What each fault did (:class:`supervisor.virtual.fault_log.Tally`); empty without one.
    oracle_changes : tuple[tuple[int, float], ...]
        ``(row, oracle cycle time [min])`` from each row on whose truth has another oracle
        than row 0's (a step in force from part ``row + 1``); ``plan_ratio`` uses it.
    """

    seed: int
    oracle_cycle_min: float
    plan_ratio: FloatArray
    op_ratio: FloatArray
    cycle_min: FloatArray
    violations: IntArray
    where: tuple[tuple[int, str, str], ...]
    stopped_at: int
    stopped_op: str
    parts_made: int
    unavoidable_at: tuple[int, ...] = (1,)
    tallies: tuple[Tally, ...] = ()
    oracle_changes: tuple[tuple[int, float], ...] = ()

    @property
    def stopped(self) -> bool:
        """Whether the scenario stopped for want of a safe setpoint."""
        return self.stopped_at > 0

    def _at_unavoidable(self) -> list[int]:
        """Indices into ``violations`` of the unavoidable parts made."""
        return [p - 1 for p in self.unavoidable_at if p <= self.parts_made]

    @property
    def unavoidable_violations(self) -> int:
        """Violations at an unavoidable part (the first, or the first after a step)."""
        return int(sum(int(self.violations[i]) for i in self._at_unavoidable()))

    @property
    def avoidable_violations(self) -> int:
        """Violations at every other part."""
        return int(self.violations.sum()) - self.unavoidable_violations

    @property
    def avoidable_violating_parts(self) -> int:
        """Parts not at an unavoidable position that crossed a true limit."""
        bad = int(np.count_nonzero(self.violations))
        return bad - sum(1 for i in self._at_unavoidable() if self.violations[i])

    @property
    def avoidable_parts_made(self) -> int:
        """Parts made not at an unavoidable position."""
        return self.parts_made - len(self._at_unavoidable())


@dataclass(frozen=True, eq=False)
class Certificate:
    """Every scenario of one strategy on one plan, in seed order.

    Parameters
    ----------
    plan : str
        The plan's name.
    strategy : str
        The RCB strategy (a name of :data:`supervisor.rcb.strategies.STRATEGY_NAMES`).
    seed : int
        The first scenario's seed.
    parts : int
        Parts per scenario, ``K``.
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current over an edge's life [-].
    scenarios : tuple[ScenarioTrace, ...]
        One per seed ``seed .. seed + N − 1``, in that order.
    seconds : float
        Wall time of the scenarios (without starting worker processes) [s].
    faults : Faults
        The faults of the shop floor (:mod:`supervisor.virtual.fault_spec`; wear drift is
        its ``wear`` fault); ``Faults()`` for none.
    """

    plan: str
    strategy: str
    seed: int
    parts: int
    wear_drift_per_edge_life: float
    scenarios: tuple[ScenarioTrace, ...]
    seconds: float
    faults: Faults = Faults()

    @property
    def plan_ratio(self) -> FloatArray:
        """``(scenarios, parts + 1)``: plan MRR/oracle after ``k`` parts [-]."""
        return np.array([s.plan_ratio for s in self.scenarios])

    @property
    def op_ratio(self) -> FloatArray:
        """``(scenarios, parts + 1, operations)``: MRR/oracle per operation [-]."""
        return np.array([s.op_ratio for s in self.scenarios])

    @property
    def cumulative_violations(self) -> IntArray:
        """``(parts + 1,)``: row ``k``, the violations of parts ``1..k`` over all scenarios."""
        per_part = np.array([s.violations for s in self.scenarios]).sum(axis=0)
        return np.concatenate([np.zeros(1, dtype=np.int64), np.cumsum(per_part)])

    @property
    def violations(self) -> int:
        """True-limit violations over all scenarios and parts (a part may cross several)."""
        return int(sum(int(s.violations.sum()) for s in self.scenarios))

    @property
    def unavoidable_violations(self) -> int:
        """Violations at unavoidable parts (:attr:`ScenarioTrace.unavoidable_at`)."""
        return sum(s.unavoidable_violations for s in self.scenarios)

    @property
    def avoidable_violations(self) -> int:
        """Violations at every other part."""
        return sum(s.avoidable_violations for s in self.scenarios)

    @property
    def parts_made(self) -> int:
        """Parts made over all scenarios (a stopped scenario makes no more)."""
        return sum(s.parts_made for s in self.scenarios)

    @property
    def stopped(self) -> int:
        """Scenarios that stopped for want of a safe setpoint."""
        return sum(1 for s in self.scenarios if s.stopped)

    def mean_cycle(self, row: int) -> tuple[float, int]:
        """Mean cycle time after ``row`` parts over the running scenarios [min], and how many."""
        values = np.array([s.cycle_min[row] for s in self.scenarios])
        running = values[np.isfinite(values)]
        return (float(running.mean()) if running.size else float("nan")), int(running.size)


@dataclass(frozen=True)
class SummaryRow:
    """Parts ``1..k`` of every scenario, and MRR/oracle after them.

    Parameters
    ----------
    after_parts : int
        ``k``.
    parts_made : int
        Parts made among parts ``1..k`` of every scenario (a stopped scenario makes no more).
    violations : int
        True-limit violations of those parts (a part may cross several limits).
    violating_parts : int
        Those parts that crossed at least one true limit.
    violation_probability_upper_95 : float
        One-sided 95 % Clopper-Pearson upper bound on the probability that a part crosses a
        true limit, from ``violating_parts`` in ``parts_made`` [-].
    mrr_over_oracle_mean, mrr_over_oracle_p5 : float
        Mean and 5th percentile (numpy's linear interpolation) over scenarios of the plan's
        MRR/oracle with the setpoints in force after ``k`` parts (0 for a stopped one) [-].
    """

    after_parts: int
    parts_made: int
    violations: int
    violating_parts: int
    violation_probability_upper_95: float
    mrr_over_oracle_mean: float
    mrr_over_oracle_p5: float


@dataclass(frozen=True)
class CertificateSummary:
    """What a certificate says, in numbers.

    Parameters
    ----------
    plan, strategy : str
        The plan's name and the RCB strategy.
    scenarios, parts, seed : int
        Scenarios, parts per scenario and the first seed.
    wear_drift_per_edge_life : float
        Wear drift of the virtual machines [-].
    stopped : int
        Scenarios that stopped for want of a safe setpoint.
    rows : tuple[SummaryRow, ...]
        After ``k`` parts for ``k`` in :func:`summary_rows`; the last (``k = parts``) covers
        every part, and the totals below are its.
    faults : tuple[str, ...]
        The faults, ``KIND:ARGS``, in order (empty for none).
    unavoidable_violations, avoidable_violations : int
        Violations at unavoidable parts (the first of a scenario, the first after a step)
        and at every other part; they add up to ``violations``.
    avoidable_violating_parts, avoidable_parts_made : int
        Parts not at an unavoidable position that crossed a true limit, and that were made.
    avoidable_probability_upper_95 : float
        One-sided 95 % Clopper-Pearson upper bound on the probability that such a part
        crosses a true limit [-].
    fault_rows : tuple[Tally, ...]
        What each fault did over every scenario (counts summed, maxima the largest).
    """

    plan: str
    strategy: str
    scenarios: int
    parts: int
    seed: int
    wear_drift_per_edge_life: float
    stopped: int
    rows: tuple[SummaryRow, ...]
    faults: tuple[str, ...]
    unavoidable_violations: int
    avoidable_violations: int
    avoidable_violating_parts: int
    avoidable_parts_made: int
    avoidable_probability_upper_95: float
    fault_rows: tuple[Tally, ...]

    @property
    def total(self) -> SummaryRow:
        """The row of every part (``k = parts``)."""
        return self.rows[-1]

    @property
    def violations(self) -> int:
        """True-limit violations over all parts."""
        return self.total.violations

    @property
    def violation_probability_upper_95(self) -> float:
        """The bound over all parts [-]."""
        return self.total.violation_probability_upper_95


def summary_rows(parts: int) -> tuple[int, ...]:
    """The rows of a summary: :data:`SUMMARY_ROWS` up to ``parts``, and ``parts``."""
    return tuple(sorted({k for k in SUMMARY_ROWS if k <= parts} | {parts}))


def summarize(certificate: Certificate) -> CertificateSummary:
    """Violations, the bound on their probability and MRR/oracle of a certificate.

    Parameters
    ----------
    certificate : Certificate
        The scenarios.

    Returns
    -------
    CertificateSummary
        Per row of :func:`summary_rows`: violations of the parts so far, the one-sided 95 %
        Clopper-Pearson bound on them, and MRR/oracle (mean and 5th percentile).
    """
    ratio = certificate.plan_ratio
    violations = np.array([s.violations for s in certificate.scenarios])
    made = np.array([s.parts_made for s in certificate.scenarios])
    rows = []
    for k in summary_rows(certificate.parts):
        bad = int(np.count_nonzero(violations[:, :k]))
        n = int(np.minimum(made, k).sum())
        rows.append(
            SummaryRow(
                after_parts=k,
                parts_made=n,
                violations=int(violations[:, :k].sum()),
                violating_parts=bad,
                violation_probability_upper_95=clopper_pearson_upper(bad, n, CONFIDENCE),
                mrr_over_oracle_mean=float(ratio[:, k].mean()),
                mrr_over_oracle_p5=float(np.percentile(ratio[:, k], PERCENTILE)),
            )
        )
    scenarios = certificate.scenarios
    bad = sum(s.avoidable_violating_parts for s in scenarios)
    n = sum(s.avoidable_parts_made for s in scenarios)
    return CertificateSummary(
        plan=certificate.plan,
        strategy=certificate.strategy,
        scenarios=len(scenarios),
        parts=certificate.parts,
        seed=certificate.seed,
        wear_drift_per_edge_life=certificate.wear_drift_per_edge_life,
        stopped=certificate.stopped,
        rows=tuple(rows),
        faults=certificate.faults.specs,
        unavoidable_violations=certificate.unavoidable_violations,
        avoidable_violations=certificate.avoidable_violations,
        avoidable_violating_parts=bad,
        avoidable_parts_made=n,
        avoidable_probability_upper_95=clopper_pearson_upper(bad, n, CONFIDENCE),
        fault_rows=combine(t for s in scenarios for t in s.tallies),
    )


def digest(certificates: Sequence[Certificate]) -> str:
    """SHA-256 (first 12 hex digits) of every per-scenario result, in order.

    The same scenarios give the same digest whatever ``jobs`` ran them; it covers the arrays
    of every :class:`ScenarioTrace`, the oracle's cycle time, where violations happened and
    where the scenario stopped. With a fault other than wear (wear alone is the older
    ``wear_drift_per_edge_life``, whose digests stay as they were) it covers the faults, the
    unavoidable parts, the tallies and the oracle changes too; a fault-free digest is the one
    from before the fault catalogue.
    """
    h = hashlib.sha256()
    for certificate in certificates:
        h.update(certificate.strategy.encode())
        faulted = certificate.faults.beyond_wear
        if faulted:
            h.update(repr(certificate.faults.specs).encode())
        for s in certificate.scenarios:
            for array in (s.plan_ratio, s.op_ratio, s.cycle_min, s.violations):
                h.update(np.ascontiguousarray(array).tobytes())
            h.update(repr((s.oracle_cycle_min, s.where, s.stopped_at, s.stopped_op)).encode())
            if faulted:
                h.update(repr((s.unavoidable_at, s.tallies, s.oracle_changes)).encode())
    return h.hexdigest()[:12]
