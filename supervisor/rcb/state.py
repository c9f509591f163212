"""RCB's state between parts: the update law's settings and the halt.

What one measurement did is a :class:`supervisor.rcb.decision.Decision`.

Frozen objects, so that a whole production history can be replayed offline
(:func:`supervisor.rcb.update.update` maps a state and a part report to the next state).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.errors import Conflict
from supervisor.inputs.plan import Plan
from supervisor.optimize.result import PlanResult
from supervisor.rcb import posterior as post
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.settings import DEFAULT_HALT_OVER as DEFAULT_HALT_OVER
from supervisor.rcb.settings import SETTINGS, settings_from_table
from supervisor.rcb.strategies import DEFAULT_ALPHA, DEFAULT_STRATEGY, REGISTRY, Strategy
from supervisor.rcb.wear import WearRise


@dataclass(frozen=True)
class RcbSettings:
    """How bands are updated.

    Parameters
    ----------
    strategy : str
        A name of :data:`supervisor.rcb.strategies.REGISTRY` (module docstring).
    alpha : float
        Fraction of the margin by which a band shrinks, ``0 < alpha <= 1`` (paper: 0.25).
    floors : Mapping[str, float]
        Least band ``ΔY`` per quantity, in its unit; default: the measurement's uncertainty.
    coverage_k : float
        ``bayes`` and ``learn``: the band is ``k σ`` of ``ln K`` (2: the paper's ±2σ).
    discrepancy : float, optional
        ``τ``, the model discrepancy [-]: ``bayes`` adds it to ``σ`` before each observation,
        ``learn`` takes it as the intercept's random walk per part; default: the strategy's
        (:attr:`supervisor.rcb.strategies.Strategy.default_discrepancy`).
    z : float
        ``learn``: the cone's multiple of the posterior standard deviation of ``ln y``.
    exponent_sd : float
        ``learn``: prior standard deviation of each exponent relative to its value [-], for a
        model without a fitted covariance.
    edge_sd : float
        Prior standard deviation of the rise over one edge's life, in ``ln`` [-]: ``learn``'s
        edge-age coefficient and every strategy's wear projection (:mod:`supervisor.rcb.wear`;
        0 turns the projection off).
    halt_over : float
        A reading past its limit by more than this fraction of the limit halts the plan [-],
        ``0 < halt_over <= 10`` (default :data:`DEFAULT_HALT_OVER`, 0.25: 25 % over), whatever a
        strategy could still find, as an adaptive control's extreme limit stops a spindle.
    """

    strategy: str = DEFAULT_STRATEGY
    alpha: float = DEFAULT_ALPHA
    floors: Mapping[str, float] = field(default_factory=dict)
    coverage_k: float = 2.0
    discrepancy: float | None = None
    z: float = post.DEFAULT_Z
    exponent_sd: float = post.DEFAULT_EXPONENT_SD
    edge_sd: float = post.DEFAULT_EDGE_SD
    halt_over: float = DEFAULT_HALT_OVER

    def __post_init__(self) -> None:
        """Each setting checked as :data:`supervisor.rcb.settings.SETTINGS` declares it."""
        for name, setting in SETTINGS.items():
            if name == "discrepancy" and self.discrepancy is None:
                object.__setattr__(self, "discrepancy", self.rule.default_discrepancy)
            setting.check(getattr(self, name), name)

    @property
    def rule(self) -> Strategy:
        """The strategy object of :attr:`strategy`."""
        return REGISTRY[self.strategy]

    @property
    def tau(self) -> float:
        """The discrepancy in force (the strategy's default when none was given)."""
        return self.rule.default_discrepancy if self.discrepancy is None else self.discrepancy


def plan_settings(
    body: Mapping[str, Any], given: Mapping[str, object] | None = None
) -> RcbSettings:
    """The settings of a plan: its ``[rcb]`` table, then ``given`` over it.

    ``given``: settings named on the command line or in the query, checked already; every
    other setting its default. A bad ``[rcb]`` entry is an error naming ``rcb.NAME``.
    """
    chosen: dict[str, Any] = {**settings_from_table(body.get("rcb")), **(given or {})}
    return RcbSettings(**chosen)


@dataclass(frozen=True)
class HaltedOperation:
    """An operation the plan halted on, and why.

    Either no setpoint can run it under the bands in force (``conflicts``: the limits that
    cannot all be met; ``against``: what else is tight), or a reading was past its limit by more
    than :attr:`RcbSettings.halt_over` (``conflicts`` and ``against`` empty; ``message`` names
    the reading, the limit and by how much).
    """

    operation: str
    conflicts: tuple[Conflict, ...]
    against: tuple[str, ...]
    message: str


@dataclass(frozen=True)
class Halt:
    """Why a plan halted: per operation, the limits that cannot all be met, or a gross breach."""

    operations: tuple[HaltedOperation, ...]

    @property
    def message(self) -> str:
        """One line per halted operation."""
        return "; ".join(o.message for o in self.operations)


@dataclass(frozen=True)
class RcbState:
    """Everything RCB needs between parts.

    Parameters
    ----------
    plan : Plan
        The plan (limits, bounds, catalogue models).
    tools : Mapping[str, Tool]
        Per operation name, the tool with the models in force: bands are kept per operation
        and quantity, as Table 5 treats steps 2 and 3 (both VCMR331).
    setpoints : PlanResult
        The current robust optimum under those models (while halted: the last setpoints).
    version : int
        Setpoint version, 1 for the initial robust optimum.
    settings : RcbSettings
        The update law.
    sigma : Mapping[tuple[str, str], float]
        ``bayes``: posterior standard deviation of ``ln K`` per (operation, quantity).
    seen : Mapping[tuple[str, str], float]
        Per (operation, quantity), the most demanding measurement so far as a K-equivalent:
        the largest ``(y + u)/Π x_i^e_i`` for a maximum, the smallest ``(y − u)/Π x_i^e_i``
        for a minimum. A band never shrinks so far that it stops covering it, as Ivester &
        Heigel's bands are "the range of K that encompasses all of the points".
    posterior : Mapping[tuple[str, str], Posterior]
        ``learn``: the posterior of ``(ln K, exponents)`` per (operation, quantity) measured.
    wear : Mapping[tuple[str, str], WearRise]
        Per (operation, wearing quantity) of an operation with a ``parts_per_edge`` limit, the
        rise per part an edge makes (:mod:`supervisor.rcb.wear`), learned from the readings.
    halt : Halt or None
        Set when the bands leave no safe setpoint or a reading is past its limit by more than
        ``settings.halt_over``; only a replan clears it.
    monitors : Mapping[tuple[str, str], Monitor]
        Per (operation, quantity) measured: the noise scale, the last reading learned from and
        a quarantined one (:mod:`supervisor.rcb.monitor`).
    priors : Mapping[tuple[str, str], Posterior]
        ``learn``: per (operation, quantity), the prior the posterior started from where it is
        not the catalogue's (a fleet prior, :mod:`supervisor.fleet.prior`).
    noise_priors : Mapping[str, NoiseScale]
        ``learn``: per quantity, the prior of the noise scale of the chain that reads it where
        it is a fleet's (:mod:`supervisor.fleet.noise`) and its readings have not let it go
        (:mod:`supervisor.rcb.noise_check`); else the default.
    """

    plan: Plan
    tools: Mapping[str, Tool]
    setpoints: PlanResult
    version: int
    settings: RcbSettings
    sigma: Mapping[tuple[str, str], float] = field(default_factory=dict)
    seen: Mapping[tuple[str, str], float] = field(default_factory=dict)
    posterior: Mapping[tuple[str, str], Posterior] = field(default_factory=dict)
    halt: Halt | None = None
    wear: Mapping[tuple[str, str], WearRise] = field(default_factory=dict)
    monitors: Mapping[tuple[str, str], Monitor] = field(default_factory=dict)
    priors: Mapping[tuple[str, str], Posterior] = field(default_factory=dict)
    noise_priors: Mapping[str, NoiseScale] = field(default_factory=dict)


def prior_sigma(model: PowerLawModel, settings: RcbSettings) -> float:
    """σ of ln K before any measurement: the band read as ±k σ, ``(ΔK/K)/k``."""
    return (model.dK / model.K) / settings.coverage_k
