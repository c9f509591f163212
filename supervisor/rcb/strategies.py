r"""RCB strategies behind one protocol, and their registry.

A strategy decides what a measurement teaches besides the band law of :mod:`supervisor.rcb.law`
(the one-sided law of Ivester & Heigel, common to all): ``ivester`` nothing more, ``bayes`` a
conjugate update of ``ln K``, ``learn`` a Bayesian regression of the whole power law
(:mod:`supervisor.rcb.learning`). :func:`supervisor.rcb.update.update` runs every strategy
through the same hooks, in this order, for each reading:

1. :meth:`Strategy.expects`: what the strategy expects of the reading, on the low side (is it
   too good to be true?) and the high side (has the process changed?), judged by
   :func:`supervisor.rcb.monitor.watch`;
2. :meth:`Strategy.forget`: a change discounts the old regime's evidence;
3. :meth:`Strategy.adjust` and :meth:`Strategy.least_band`: inside the band law;
4. :meth:`Strategy.learn`: what the strategy keeps beyond the band (``learn``: its posterior);
5. :meth:`Strategy.settle`: once every reading of the report is in, what it keeps is counted at
   the measuring chains' noise as the whole report shows it;
6. :meth:`Strategy.cones`: the constraints it hands the optimiser beyond the band.

The CLI's choices, the REST enum, the stored plan settings and the docs all come from
:data:`REGISTRY`; a new strategy is one class here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:  # only named in signatures: the registry loads no NumPy (rcb --help reads it)
    from models.powerlaw import PowerLawModel
    from supervisor.inputs.part_report import Measurement
    from supervisor.inputs.plan import Operation
    from supervisor.optimize.result import OperationResult
    from supervisor.rcb.beliefs import Beliefs
    from supervisor.rcb.cone import Cone
    from supervisor.rcb.decision import Decision
    from supervisor.rcb.monitor import Watched
    from supervisor.rcb.monitor_state import Expected, Monitor
    from supervisor.rcb.noise import NoiseScale
    from supervisor.rcb.posterior import Posterior

#: The ``learn`` strategy's random walk of the intercept per part [-]
#: (:mod:`supervisor.rcb.posterior`). 0 by default: with wear a regressor (edge age), the
#: closed-loop benchmark's drift is explained by the model; 0.001 cost 0.004 of MRR/oracle
#: after 30 parts there (README). Set it for a process that drifts in ways the power law and
#: the edge age do not capture.
DEFAULT_DRIFT = 0.0


class Strategy:
    """The ``ivester`` strategy, and the hooks every other strategy may change.

    ``learns_model`` says the strategy keeps a posterior of the whole power law and hands the
    optimiser a second-order-cone constraint (:meth:`cones`).
    """

    name: ClassVar[str] = "ivester"
    summary: ClassVar[str] = "the paper's law on the band alone (K and exponents stay)"
    learns_model: ClassVar[bool] = False
    #: The discrepancy ``τ`` a plan gets when it names none (unused by ``ivester``).
    default_discrepancy: ClassVar[float] = 0.02

    def expects(
        self,
        state: Beliefs,
        operation: Operation,
        result: OperationResult,
        quantity: str,
        age: int | None,
        monitor: Monitor,
        chain: NoiseScale | None = None,
    ) -> tuple[Expected, Expected | None]:
        """What a reading at ``result``'s setpoint should be: ``(low side, high side)``.

        The high side is the last reading learned from, moved to this setpoint with the
        model's exponents (:func:`supervisor.rcb.monitor.chain`; None before the first). The
        low side is the same once there is one, else the catalogue model and its band read as
        ``k σ`` (the truth lies in it, Ivester & Heigel: the band "encompasses all of the
        points"; the band in force is one-sided and says nothing of how low a reading may
        be). Against the catalogue's wide band a reading at 26 % of the truth escaped the
        quarantine (``r = −4.5``), taught the noise scale a 3x noisier chain and shrank the
        band; against the last reading it is ``r = −40``. Measured on
        ``benchmarks/closed_loop.py``, ``ivester``, 1000 scenarios x 30 parts, all five
        faults: 10 scenarios stopped with no safe setpoint and 15 avoidable crossings
        against the catalogue, none stopped and 12 against the last reading; dropout alone,
        1 stopped and none.
        """
        from supervisor.rcb import monitor as watcher
        from supervisor.rcb.monitor_state import Expected  # the module-level one is typing-only

        settings = state.settings
        point = {**result.setpoint, **operation.context}
        rel = operation.setpoint_rel_uncertainty
        catalogue = state.plan.tools[operation.tool].models[quantity].predict(point, rel)
        low = Expected(
            math.log(catalogue.value), (catalogue.band / catalogue.value) / settings.coverage_k
        )
        exponents = state.tools[operation.name].models[quantity].exponents
        worn = state.wear.get((operation.name, quantity))
        rise = None if worn is None else (worn.mean, worn.var)
        high = watcher.chain(monitor, point, exponents, settings.exponent_sd, age, rise)
        return (low if high is None else high), high

    def forget(self, sigma: float, variance: float) -> float:
        """σ of ``ln K`` after a change that discounts ``variance`` of evidence (here as is)."""
        return sigma

    def adjust(
        self,
        model: PowerLawModel,
        point: Mapping[str, float],
        measurement: Measurement,
        sigma: float,
        coverage_k: float,
        discrepancy: float,
    ) -> tuple[PowerLawModel, float]:
        """The model the band law then acts on, and the new σ of ``ln K`` (here unchanged)."""
        return model, sigma

    def least_band(
        self, band: float, sigma: float, value: float, coverage_k: float, discrepancy: float
    ) -> float:
        """The least band the law may shrink to at the measured setpoint (here ``band``)."""
        return band

    def learn(
        self,
        state: Beliefs,
        operation: Operation,
        result: OperationResult,
        law: Decision,
        measurement: Measurement,
        watched: Watched,
        age: int | None,
    ) -> tuple[bool, Posterior | None, Decision]:
        """After the law: ``(keep the law's model, the posterior, the decision)``.

        Here the law's model is the model in force, no posterior is kept, and the decision
        is the law's.
        """
        return True, None, law

    def moved(
        self, state: Beliefs, operation: Operation, quantity: str, shift: float, variance: float
    ) -> Posterior | None:
        """The posterior of an operation whose reading of a common change was quarantined.

        ``shift`` and ``variance``: the change the other operations showed
        (:mod:`supervisor.rcb.common_cause`); here no posterior is kept.
        """
        return None

    def settle(
        self, state: Beliefs, chains: Mapping[str, NoiseScale]
    ) -> dict[tuple[str, str], Posterior]:
        """The posteriors the report's end changes, per operation and quantity (here none).

        ``state``: the beliefs after every reading of the report; ``chains``: per quantity,
        the measuring chain's noise scale with all of the report's readings in.
        """
        return {}

    def cones(self, state: Beliefs) -> dict[str, dict[str, Cone]]:
        """Per operation and quantity, the constraints beyond the band (here none)."""
        return {}


class Bayes(Strategy):
    r"""The law, and a conjugate normal update of ``ln K`` (:mod:`supervisor.rcb.update`)."""

    name: ClassVar[str] = "bayes"
    summary: ClassVar[str] = "the law, and a conjugate update of ln K (exponents stay)"

    def forget(self, sigma: float, variance: float) -> float:
        """The old regime discounted: ``σ² + q``, a random-walk step of ``ln K``."""
        return math.sqrt(sigma**2 + variance)

    def adjust(
        self,
        model: PowerLawModel,
        point: Mapping[str, float],
        measurement: Measurement,
        sigma: float,
        coverage_k: float,
        discrepancy: float,
    ) -> tuple[PowerLawModel, float]:
        """Conjugate normal update of ``ln K`` (Gelman et al. §2.5), with the discrepancy.

        ``measurement``'s ``u`` is the chain's bound ``Q u`` (:mod:`supervisor.rcb.law`, at
        least the reported ``u``): the update weighs a reading by the variance it is read
        at, and read at ``u`` a chain noisier than it says (``noise-scale:3``) or one
        reading 4.9 σ low (seed 902) moved ``K`` far enough to put the next setpoint past a
        limit (docs/benchmarks.md, *bayes reads its readings at the chain's bound*).
        """
        if measurement.value <= 0:
            return model, sigma
        shape = model.predict(point).value / model.K  # Π x_i^e_i
        z = math.log(measurement.value) - math.log(shape)
        prior_var = sigma**2 + discrepancy**2
        obs_var = max((measurement.uncertainty / coverage_k) / measurement.value, 1e-9) ** 2
        post_var = 1.0 / (1.0 / prior_var + 1.0 / obs_var)
        mu = post_var * (math.log(model.K) / prior_var + z / obs_var)
        K = math.exp(mu)
        return replace(model, K=K, dK=model.dK * K / model.K), math.sqrt(post_var)

    def least_band(
        self, band: float, sigma: float, value: float, coverage_k: float, discrepancy: float
    ) -> float:
        """At least ``k·sqrt(σ'² + τ²)`` of the value: the spread at the next setpoint."""
        return max(band, coverage_k * math.hypot(sigma, discrepancy) * value)


class Learn(Strategy):
    """The law as ``ivester`` (the proven-safe fallback) and a posterior of the whole model.

    Its hooks are :mod:`supervisor.rcb.learning`'s (imported when used: NumPy).
    """

    name: ClassVar[str] = "learn"
    summary: ClassVar[str] = (
        "learns ln K and the exponents (Bayesian regression), robust by a second-order cone"
    )
    learns_model: ClassVar[bool] = True
    default_discrepancy: ClassVar[float] = DEFAULT_DRIFT

    def expects(
        self,
        state: Beliefs,
        operation: Operation,
        result: OperationResult,
        quantity: str,
        age: int | None,
        monitor: Monitor,
        chain: NoiseScale | None = None,
    ) -> tuple[Expected, Expected | None]:
        """The posterior predictive of ``ln y`` at the setpoint, on both sides."""
        from supervisor.rcb import learning

        expected = learning.expects(state, operation, result, quantity, age, chain)
        return expected, expected

    def learn(
        self,
        state: Beliefs,
        operation: Operation,
        result: OperationResult,
        law: Decision,
        measurement: Measurement,
        watched: Watched,
        age: int | None,
    ) -> tuple[bool, Posterior | None, Decision]:
        """The fallback band only grows; the posterior learns the reading (and a held one)."""
        from supervisor.rcb import learning

        belief, decision = learning.learn(state, operation, result, law, measurement, watched, age)
        return law.action == "expand", belief, decision

    def moved(
        self, state: Beliefs, operation: Operation, quantity: str, shift: float, variance: float
    ) -> Posterior | None:
        """The posterior moved by the change and discounted by its variance."""
        from supervisor.rcb import learning

        return learning.moved(state, operation, quantity, shift, variance)

    def settle(
        self, state: Beliefs, chains: Mapping[str, NoiseScale]
    ) -> dict[tuple[str, str], Posterior]:
        """Every posterior counted at its chain's prudent scale after the whole report."""
        from supervisor.rcb import learning

        return learning.settled(state, chains)

    def cones(self, state: Beliefs) -> dict[str, dict[str, Cone]]:
        """The posterior's cone per operation and quantity (:mod:`supervisor.rcb.posterior`)."""
        from supervisor.rcb import learning

        return learning.cones(state)


#: Every strategy by name, in the order the docs list them.
REGISTRY: Mapping[str, Strategy] = {s.name: s for s in (Learn(), Strategy(), Bayes())}
#: Names of :data:`REGISTRY`.
STRATEGY_NAMES: tuple[str, ...] = tuple(REGISTRY)
#: The strategy a plan gets when none is named.
DEFAULT_STRATEGY = "learn"
#: The paper's fraction of the margin a band shrinks by (Ivester & Heigel, "0.25").
DEFAULT_ALPHA = 0.25
