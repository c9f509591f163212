r"""What the fleet learned of a tool's law, beside the catalogue's (``rcb fleet law``).

A process engineer asks what the plans that used an insert on a material found: is its ``K``
what the catalogue says, do its exponents hold, how much do the machines differ? The fleet's
belief (:func:`supervisor.fleet.prior.tool_beliefs`, the hierarchical model of
:mod:`supervisor.fleet.hierarchy`) is over ``θ = (ln K, e_1 … e_n[, ω])`` in the tool's own
terms, so each parameter is set beside the catalogue prior's. ``K`` alone says little about
how well the law is known: it is ``Y`` extrapolated to every input at 1 (1 mm, 1 m/min),
far from where any machine cut, and its uncertainty there is mostly the exponents'. The law
is known best where the machines' readings pin it (``φ = (1, x_r[, 0])``,
:func:`~supervisor.fleet.spread.best_determined`), so the uncertainty of ``ln Y`` is given
there: the fleet's law, a new machine's operation (the law with the between-machine spread
``σ_b`` and the operation's ``σ_o``: what a new plan's first part holds its cone to) and the
catalogue's, each as a standard deviation of ``ln Y`` (a fraction of ``Y``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from supervisor.fleet.prior import ToolBelief
from supervisor.fleet.provenance import Provenance


@dataclass(frozen=True)
class Parameter:
    """One parameter of ``θ`` after ``ln K``: the fleet's mean and sd, the catalogue's.

    ``name``: an exponent's input (``feed_mm_rev``) or ``edge_rise`` (``ω``, the rise of
    ``ln Y`` over an edge's life, where an operation of the fleet had an edge limit). The
    fleet's sd is a new machine's (the law's and the machines' spread of it).
    """

    name: str
    fleet: float
    fleet_sd: float
    catalogue: float
    catalogue_sd: float


@dataclass(frozen=True)
class FleetLaw:
    """The fleet's law of one quantity of a tool (module docstring).

    ``reference``: the inputs (their units) where the machines' readings pin ``ln Y`` best, on
    a new edge; ``law_sd``, ``new_machine_sd``, ``catalogue_sd``: the sd of ``ln Y`` there.
    """

    quantity: str
    K: float
    catalogue_K: float
    parameters: tuple[Parameter, ...]
    reference: dict[str, float]
    law_sd: float
    new_machine_sd: float
    catalogue_sd: float
    provenance: Provenance


def fleet_law(belief: ToolBelief) -> FleetLaw:
    """``belief`` set beside the catalogue's (module docstring)."""
    names = belief.names
    mean, cov, law_cov = belief.belief.mean, belief.belief.cov, belief.belief.law_cov
    prior_mean, prior_cov = belief.catalogue
    shown = len(names) + (1 if belief.edge_seen else 0)  # ω the fleet never saw: not shown
    labels = [*names, "edge_rise"][:shown]
    parameters = tuple(
        Parameter(
            label,
            float(mean[i]),
            _sd(cov[i, i]),
            float(prior_mean[i]),
            _sd(prior_cov[i, i]),
        )
        for i, label in enumerate(labels, start=1)
    )
    phi = belief.reference
    x_r = phi[1 : len(names) + 1]
    provenance = belief.provenance
    return FleetLaw(
        provenance.quantity,
        math.exp(float(mean[0])),
        math.exp(float(prior_mean[0])),
        parameters,
        {name: math.exp(float(x)) for name, x in zip(names, x_r, strict=True)},
        _sd(phi @ law_cov @ phi),
        _sd(phi @ cov @ phi + provenance.operation_spread**2),
        _sd(phi @ prior_cov @ phi),
        provenance,
    )


def _sd(variance: float | np.floating) -> float:
    return math.sqrt(max(0.0, float(variance)))
