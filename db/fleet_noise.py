"""``plans.noise_prior``: a plan's chains' noise priors from the fleet, stored and answered.

Per quantity (:mod:`supervisor.fleet.noise`, alembic 0019): the inverse gamma's ``shape`` and
``rate``, and a provenance shown with the plan's fleet priors on every surface; once a part's
readings let it go (:mod:`supervisor.rcb.noise_check`), that part's serial, and the state no
longer loads it (a reset of the bands does not bring it back).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from db.fleet_names import listed
from db.let_go_mark import marked
from supervisor.fleet.noise import NoisePrior
from supervisor.rcb.noise import NoiseScale


def noise_prior_json(priors: Mapping[str, NoisePrior]) -> dict[str, Any] | None:
    """``plans.noise_prior`` of a plan's chains' fleet priors (None: the default's)."""
    if not priors:
        return None
    return {
        quantity: {
            "shape": p.belief.shape,
            "rate": p.belief.rate,
            "provenance": {
                "quantity": quantity,
                **listed("machines", p.machines),
                "readings": p.readings,
                "noise_scale": p.scale,
                "between_chain_spread": p.spread,
                "let_go_by_part": None,
                "text": p.describe(),
            },
        }
        for quantity, p in sorted(priors.items())
    }


def noise_priors_of(stored: Mapping[str, Any] | None) -> dict[str, NoiseScale]:
    """The noise priors per quantity a plan's state holds: those no part let go."""
    return {
        quantity: NoiseScale(float(value["shape"]), float(value["rate"]))
        for quantity, value in (stored or {}).items()
        if value["provenance"]["let_go_by_part"] is None
    }


def noise_let_go(
    stored: Mapping[str, Any] | None,
    before: Mapping[str, NoiseScale],
    after: Mapping[str, NoiseScale],
    serial: str,
) -> dict[str, Any] | None:
    """``plans.noise_prior`` with those part ``serial`` let go marked (None: none was)."""
    gone = sorted(q for q in before if q not in after and q in (stored or {}))
    if not stored or not gone:
        return None
    why = "this machine's chain reads noisier than the fleet's (its noise learned from the default)"
    return {**stored, **{q: marked(stored[q], "let_go_by_part", serial, why) for q in gone}}


def noise_provenance(stored: Mapping[str, Any] | None) -> list[dict[str, Any]]:
    """The provenance of each chain's noise prior, by quantity (empty: the default's)."""
    return [value["provenance"] for _, value in sorted((stored or {}).items())]
