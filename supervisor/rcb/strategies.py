r"""RCB strategies behind one protocol, and their registry.

A strategy decides what a measurement teaches besides the band law of :mod:`supervisor.rcb.update`
(the one-sided law of Ivester & Heigel, common to all): ``ivester`` nothing more, ``bayes`` a
conjugate update of ``ln K``, ``learn`` a Bayesian regression of the whole power law
(:mod:`supervisor.rcb.posterior`). The CLI's choices, the REST enum, the stored plan settings and
the docs all come from :data:`REGISTRY`; a new strategy is one class here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:  # only named in signatures: the registry loads no NumPy (rcb --help reads it)
    from models.powerlaw import PowerLawModel
    from supervisor.inputs.part_report import Measurement

#: The ``learn`` strategy's random walk of the intercept per part [-]
#: (:mod:`supervisor.rcb.posterior`). 0 by default: with wear a regressor (edge age), the
#: closed-loop benchmark's drift is explained by the model; 0.001 cost 0.004 of MRR/oracle
#: after 30 parts there (README). Set it for a process that drifts in ways the power law and
#: the edge age do not capture.
DEFAULT_DRIFT = 0.0


class Strategy:
    """The ``ivester`` strategy, and the hooks every other strategy may change.

    ``adjust`` runs before the band law (it may move K), ``least_band`` bounds the band the
    law gives from below; ``learns_model`` says the strategy keeps a posterior of the whole
    power law and hands the optimiser a second-order-cone constraint.
    """

    name: ClassVar[str] = "ivester"
    summary: ClassVar[str] = "the paper's law on the band alone (K and exponents stay)"
    learns_model: ClassVar[bool] = False
    #: The discrepancy ``τ`` a plan gets when it names none (unused by ``ivester``).
    default_discrepancy: ClassVar[float] = 0.02

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


class Bayes(Strategy):
    r"""The law, and a conjugate normal update of ``ln K`` (:mod:`supervisor.rcb.update`)."""

    name: ClassVar[str] = "bayes"
    summary: ClassVar[str] = "the law, and a conjugate update of ln K (exponents stay)"

    def adjust(
        self,
        model: PowerLawModel,
        point: Mapping[str, float],
        measurement: Measurement,
        sigma: float,
        coverage_k: float,
        discrepancy: float,
    ) -> tuple[PowerLawModel, float]:
        """Conjugate normal update of ``ln K`` (Gelman et al. §2.5), with the discrepancy."""
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
    """The law as ``ivester`` (the proven-safe fallback) and a posterior of the whole model."""

    name: ClassVar[str] = "learn"
    summary: ClassVar[str] = (
        "learns ln K and the exponents (Bayesian regression), robust by a second-order cone"
    )
    learns_model: ClassVar[bool] = True
    default_discrepancy: ClassVar[float] = DEFAULT_DRIFT


#: Every strategy by name, in the order the docs list them.
REGISTRY: Mapping[str, Strategy] = {s.name: s for s in (Learn(), Strategy(), Bayes())}
#: Names of :data:`REGISTRY`.
STRATEGY_NAMES: tuple[str, ...] = tuple(REGISTRY)
#: The strategy a plan gets when none is named.
DEFAULT_STRATEGY = "learn"
#: The paper's fraction of the margin a band shrinks by (Ivester & Heigel, "0.25").
DEFAULT_ALPHA = 0.25
