"""A fleet prior and where it came from, the line every surface shows with it.

:func:`supervisor.fleet.prior.fleet_priors` makes them; the database stores the provenance
(``db/fleet.py``) and the REST service, the CLI and the report show :meth:`Provenance.describe`.
"""

from __future__ import annotations

from dataclasses import dataclass

from supervisor.fleet.band_check import BAND_CHECKED_WHY
from supervisor.fleet.hierarchy import DEFAULT_OPERATION_SPREAD
from supervisor.fleet.left_out import LeftOut
from supervisor.rcb.posterior import Posterior

#: The sd at which a fleet prior's cones veto the catalogue band's optimum where the band
#: holds too few of the fleet's machines (:func:`.prior._beyond_band`), or a plan of the tool
#: halted (:func:`.prior._prior`); else at the mean.
#: Measured (docs/benchmarks.md, "The band's veto"; 200 scenarios, machines 20 % apart):
#: first-part crossings 237 -> 63 in 180 new machines, 0.793 -> 0.912 of the oracle after
#: 3 parts; machines 3 % apart, no change.
FLEET_VETO_Z = 2.0


def beyond_band(spread: float, band_rel: float) -> bool:
    """Whether :data:`FLEET_VETO_Z` spreads of ln K pass a band's ``dK/K`` (``band_rel``).

    More than one machine in 20 then lies outside the band, and its optimum is checked at
    ``FLEET_VETO_Z`` sd. ``spread``: what the caller knows of it (a fleet prior, its lower
    credible bound: :func:`.prior._beyond_band`; the benchmark's known reference, the truth).
    """
    return FLEET_VETO_Z * spread > band_rel


@dataclass(frozen=True)
class Provenance:
    """Where a fleet prior came from: shown with it on every surface."""

    quantity: str
    plans: tuple[str, ...]
    machines: tuple[str, ...]
    spread: float
    readings: int
    #: ``σ_o``, learned where a machine ran the tool in two operations (hierarchy).
    operation_spread: float = DEFAULT_OPERATION_SPREAD
    #: Why the band's optimum is checked at :data:`FLEET_VETO_Z` sd, by the keys of
    #: :data:`BAND_CHECKED_WHY` ("spread", "halted"; empty: at the mean; prior._prior).
    band_checked_why: tuple[str, ...] = ()
    #: The tool's plans left out of the fleet, among its machines' newest (db.fleet_left_out).
    left_out: LeftOut = LeftOut()

    @property
    def band_checked_at_sd(self) -> float | None:
        """The sd the band's optimum is checked at (the prior's band_veto_z; None: the mean)."""
        return FLEET_VETO_Z if self.band_checked_why else None

    def describe(self) -> str:
        """One line: ``force_N: prior from 3 plans on 2 machines, …, 96 readings``.

        Between them the spreads: ``between-machine spread 4.1 %, between operations 2.0 %``;
        after them, where the band is checked and what the fleet left out.
        """
        if not self.plans:
            return f"{self.quantity}: catalogue prior (no plan of the fleet measured it)"
        plans = "plan" if len(self.plans) == 1 else "plans"
        machines = "machine" if len(self.machines) == 1 else "machines"
        why = " and ".join(BAND_CHECKED_WHY[r] for r in self.band_checked_why)
        vetoed = f"; {why}: checked at {FLEET_VETO_Z:g} sd" if why else ""
        out = self.left_out.describe()
        vetoed += f"; {out}: rcb fleet show says why" if out else ""
        return (
            f"{self.quantity}: prior from {len(self.plans)} {plans} on {len(self.machines)} "
            f"{machines}, between-machine spread {100 * self.spread:.1f} %, between operations "
            f"{100 * self.operation_spread:.1f} %, {self.readings} readings{vetoed}"
        )


@dataclass(frozen=True)
class FleetPrior:
    """An operation's prior for one quantity and its provenance."""

    posterior: Posterior
    provenance: Provenance
