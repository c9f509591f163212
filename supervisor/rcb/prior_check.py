r"""Whether a fleet prior holds on this machine: its readings checked against it (issue 32).

A plan started from a fleet prior (:mod:`supervisor.fleet.prior`) believes its machine's
``ln K`` lies within the fleet's between-machine spread. A machine outside it (another spindle,
another coolant, a fixture that rings) reads far from that belief, and ``learn`` would explain
the readings the wrong way: the innovation, several σ of a narrow prior, teaches the measuring
chain a noise scale ten times the one it claims (:mod:`supervisor.rcb.monitor`), its readings
then weigh a hundredth of what they are worth and the cone stays where the fleet put it, past
the limit for parts on end (``closed_loop.py --fleet 4 --fleet-spread 0.06``, seeds 49 and 99:
finish-od's roughness crossed at parts 1-4 from the fleet prior, never from the catalogue).

The check is the between-machine law made robust: the machine's offset is drawn from the
fleet's normal spread, or, with probability :data:`OUTLIER_PROBABILITY`, from a law as wide as
the catalogue's band (a two-component scale mixture, the heavy tail that lets data reject a
conflicting prior: O'Hagan 1979 [1]_). Before each reading of a quantity whose prior is a
fleet's and not yet widened, the Bayes factor of the two for every reading so far,
this one included, is

.. math::

    \ln B = \ln p(y \mid S_w) − \ln p(y \mid S), \qquad
    \ln p(y \mid N(m, P^{-1})) = \tfrac12\big(\ln|P| − \ln|P'| + b^T P'^{-1} b − m^T P m\big)
    + c(y)

(the Gaussian linear model's evidence [2]_; ``P' = P + J``, ``b = P m + h``, ``J`` and ``h``
the readings' own information, which the belief keeps and a change's discount steps as it
steps the belief: :mod:`supervisor.rcb.information`, as :func:`rebased` and the fleet read
it), with ``S`` the fleet prior and
``S_w`` the same with the intercept's variance grown by the catalogue prior's. When the
posterior odds favour the wide law, ``B > (1 − ε)/ε``, the prior is widened for good: the
belief becomes ``S_w`` with the earlier readings' information, and the reading is then learned
and judged against it as usual. The exponents and the edge's rise stay the fleet's (the tool's,
with a machine's small spread about each: :mod:`supervisor.fleet.hierarchy`); only the
machine's own ``ln K`` is let go. Widening only grows the
cone: it can slow a plan, never make it less safe. Asymptotically a machine is let go when its
offset lies beyond about three spreads of the fleet's. A reading the monitor quarantines
against the fleet's belief as too good to be true (:mod:`supervisor.rcb.monitor`: a loose
cable, an air cut) is not weighed: a glitch must not throw away what the fleet learned; a
fall the next reading confirms is a change, whose discount lets ``ln K`` go as the monitor
sizes it. A reading that lets the prior go is judged again, against the widened belief.

References
----------
.. [1] O'Hagan (1979), "On outlier rejection phenomena in Bayes inference", J. R. Statist.
   Soc. B 41(3), 358-367; Evans & Moshonov (2006), "Checking for prior-data conflict",
   Bayesian Analysis 1(4), 893-914.
.. [2] Bishop, Pattern Recognition and Machine Learning (2006), §3.5.1 (the evidence of
   Bayesian linear regression); Kass & Raftery (1995), "Bayes factors", JASA 90(430), §3.2.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.rcb import posterior as post
from supervisor.rcb.decision import Decision
from supervisor.rcb.information import readings_of
from supervisor.rcb.judged import Judged, judge
from supervisor.rcb.learning import discount
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.state import RcbState, prior_sigma

#: The prior probability that a new machine's ``ln K`` lies outside the fleet's spread: the
#: odds ``(1 − ε)/ε = 19`` a Bayes factor must beat ("strong" evidence, Kass & Raftery 1995).
OUTLIER_PROBABILITY = 0.05
#: A belief whose precision lies under its start's by more than this fraction of the start's
#: in some direction was discounted since (a change): :func:`rebased` widens it as it is.
FORGOTTEN = 1e-6


def checked(
    state: RcbState,
    judged: Sequence[Judged],
    report: PartReport,
    chains: Mapping[str, NoiseScale],
) -> tuple[RcbState, list[Judged], dict[tuple[str, str], float]]:
    """``state`` with the fleet priors its readings reject widened (module docstring).

    ``judged``: the report's readings as the monitor judged them against the beliefs before
    (a quarantined one is not weighed); ``chains``: the measuring chains' noise scales
    (:func:`.judged.judge`), which judge a widened quantity's reading again. Returns the state,
    the readings as judged against it, and per widened (operation, quantity) the Bayes factor
    that widened it.
    """
    widened: dict[tuple[str, str], Posterior] = {}
    factors: dict[tuple[str, str], float] = {}
    for j in judged:
        key = (j.op.name, j.quantity)
        start = state.priors.get(key)
        before = state.posterior.get(key, start)
        if start is None or before is None or before.prior_widening > 0 or key in widened:
            continue
        if not (j.watched.learns and j.measurement.value > 0 and j.measurement.uncertainty > 0):
            continue  # a quarantined reading is the monitor's: a glitch must not throw the fleet
        variance = prior_sigma(state.plan.tools[j.op.tool].models[j.quantity], state.settings) ** 2
        point = {**j.made.setpoint, **j.op.context}
        age = report.edge_parts.get(j.op.name)
        found = _widened(state, start, before, variance, point, j.measurement, age)
        if found is not None:
            widened[key], factors[key] = found
    if not widened:
        return state, list(judged), {}
    state = replace(state, posterior={**state.posterior, **widened})
    again = [
        judge(
            state,
            j.op,
            j.made,
            j.quantity,
            j.measurement,
            report,
            chains.get(j.quantity, NoiseScale()),
        )
        if (j.op.name, j.quantity) in widened
        else j
        for j in judged
    ]
    return state, again, factors


def _widened(
    state: RcbState,
    start: Posterior,
    before: Posterior,
    variance: float,
    point: dict[str, float],
    measurement: Measurement,
    age: int | None,
) -> tuple[Posterior, float] | None:
    """The belief on the widened prior and its Bayes factor, or None (the fleet's holds)."""
    settings = state.settings
    counted = Measurement(
        measurement.value, measurement.uncertainty * math.sqrt(before.noise_scale2)
    )
    after = post.observe(before, point, counted, settings.coverage_k, settings.tau, age)
    factor = log_bayes_factor(start, after, variance)
    if factor is None or factor <= math.log((1 - OUTLIER_PROBABILITY) / OUTLIER_PROBABILITY):
        return None
    return rebased(before, start, variance), math.exp(min(factor, 700.0))


def log_bayes_factor(start: Posterior, after: Posterior, variance: float) -> float | None:
    """``ln B`` of the widened prior against ``start`` for the readings ``after`` holds.

    ``after``: the belief from ``start`` with every reading so far (module docstring);
    ``variance``: what the widened prior adds to the intercept's. None: a belief whose
    readings' information is not proper under one of the two priors (round-off: the
    information is projected on its evidence, positive semidefinite).
    """
    p_start, m = start.precision, start.mean_array
    info, h = readings_of(after, start)
    fleet = _log_evidence(m, p_start, info, h)
    widened = _log_evidence(m, discount(start, variance).precision, info, h)
    return None if fleet is None or widened is None else widened - fleet


def _log_evidence(
    m: np.ndarray, precision: np.ndarray, info: np.ndarray, h: np.ndarray
) -> float | None:
    """``ln p(y)`` less the terms every prior shares (module docstring); None: not proper."""
    after = precision + info
    sign0, logdet0 = np.linalg.slogdet(precision)
    sign1, logdet1 = np.linalg.slogdet(after)
    if sign0 <= 0 or sign1 <= 0:
        return None
    b = precision @ m + h
    return float(0.5 * (logdet0 - logdet1 + b @ np.linalg.solve(after, b) - m @ precision @ m))


def rebased(before: Posterior, start: Posterior, variance: float) -> Posterior:
    """``before``'s readings on ``start`` widened by ``variance`` (its intercept let go).

    The readings' information is the one ``before`` keeps (:mod:`supervisor.rcb.information`;
    one stored before 2026-12-06: ``P − P₀``'s positive part), as the fleet reads a plan's. A
    belief a change discounted since its start holds less precision than the start's in some
    direction (past :data:`FORGOTTEN`); ``P − P₀`` then sums the readings' information and the
    discount's loss, whose eigenvectors mix the intercept with the exponents: adding the whole
    difference to the widened start extrapolated the two and ran the mean off (the known
    prior under ``--fault curvature``, seed 139: ``ln Ra`` from 0.87 to 4.4 at part 8, ``K``
    past a float's range at part 12), and its positive part put evidence on an exponent that
    no reading gave (``closed_loop.py --fleet 4 --fleet-fault noise-scale:3``, seed 49, a
    machine outside the fleet: finish-od's feed exponent 1.08 ± 0.07 became 0.97 at the
    widening and 0.62 twelve parts on, the truth 1.14, and the roughness limit was crossed
    at parts 18 and 19). Such a belief's own ``ln K`` is widened
    by ``variance`` instead, as a change's discount widens it: the exponents stay what the
    readings made them (until 2026-12-06 such a belief was rebased on the positive part: in
    one dimension, where it is empty, the widened start stood and the readings were lost).
    Rebasing such a belief on its readings' own information would hold the widened start at
    its full precision where the discount grew the start's variance too: widening as it is
    stays the cautious one.
    """
    difference = before.precision - start.precision
    if np.linalg.eigvalsh(0.5 * (difference + difference.T)).min() < -FORGOTTEN * (
        start.precision_norm
    ):
        return replace(discount(before, variance), prior_widening=variance)
    wide = discount(start, variance)
    readings, vector = readings_of(before, start)
    # the widened start is proper and the readings' part semidefinite: their sum inverts
    cov = np.linalg.inv(wide.precision + readings)
    cov = 0.5 * (cov + cov.T)
    return replace(
        before,
        mean=tuple(float(v) for v in cov @ (wide.precision @ wide.mean_array + vector)),
        cov=tuple(tuple(float(v) for v in row) for row in cov),
        prior_widening=variance,
    )


def with_let_go(decision: Decision, factor: float | None) -> Decision:
    """``decision`` saying that its reading widened the fleet prior (``factor``: its B)."""
    if factor is None:
        return decision
    why = (
        f"the fleet prior does not hold on this machine (Bayes factor {factor:.3g} for an "
        "ln K outside the fleet's spread): its ln K is learned from the catalogue's band"
    )
    return replace(decision, reason=f"{decision.reason}; {why}")
