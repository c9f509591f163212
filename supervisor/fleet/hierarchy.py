r"""The fleet's belief about a tool's model: a ``ln K`` and exponent offsets per machine.

A tool cuts a material by one law on every machine, up to the machine: each machine ``m``
(its spindle, its rigidity, its coolant) has an offset ``δ_m`` in ``ln K``, drawn from a
between-machine spread that is itself learned, and offsets ``η_{m,i}`` in the exponents
``e_i``, drawn from a small fixed relative spread (a normal hierarchical model with varying
intercepts and slopes, Gelman et al. [1]_ §5.4-5.5, Gelman & Hill [3]_ §13.1):

.. math:: \ln y_m(x) = \ln y(x) + δ_m + Σ_i η_{m,i} (x_i − x_{r,i}), \qquad
   δ_m \sim N(0, σ_b^2), \quad η_{m,i} \sim N(0, (σ_e e_i)^2)

and each operation ``o`` of the tool on machine ``m`` an offset ``γ_{m,o} \sim N(0, σ_o^2)``
about its machine's ``ln K`` (:data:`DEFAULT_OPERATION_SPREAD`), with ``x`` the log-inputs,
``e_i`` the catalogue's exponents, ``σ_e``
:data:`DEFAULT_EXPONENT_SPREAD` and the exponents pivoting at ``x_r``, where the machines'
readings pin the law (the reference point of the spread, below), so that a machine's bend
is measured from where the fleet cut, not from ``x = 0``, which depends on the units. In the
tool's parameters, ``θ_m = θ + u_m``, ``u_m \sim N(0, D)``, ``D = L L^\mathsf{T}``,
``L = \begin{pmatrix} σ_b & −x_r^\mathsf{T} Σ_e \\ 0 & Σ_e \end{pmatrix}``,
``Σ_e = \operatorname{diag}(σ_e |e_i|)``, and a wearing quantity's rise over an edge's life
``ω`` an offset of its own, ``σ_ω`` (:data:`DEFAULT_EDGE_SPREAD`, the last diagonal entry of
``L``). The exponents' spread is there for the
machine whose law bends away from the fleet's: a setpoint a first reading moves along the
isoline of exponents known to a fraction of a per cent from 90 parts elsewhere crossed the
limit on a truth bent per machine (``closed_loop.py --fleet 4 --fault curvature``, seeds 111,
135, 147: rough-od's force at part 2 by 0.1 %), which the catalogue start never did. With
``σ_e`` at 2 % nothing crosses after the first part there (1 % is enough; 2 % keeps a margin)
and a clean fleet loses 0.002 of MRR after the first reading and 0.001 after the third
(1000 scenarios).

**The edge's rise.** A new edge is changed at the plan's ``parts_per_edge``, so how much a
wearing quantity rises by then is mostly the insert's on the material, and the fleet learns it
over its machines' edges; but a machine's coolant and rigidity wear an edge at their own rate.
Held as the tool's alone, the rise was known to a fraction of a per cent after 90 parts, and a
new machine whose edges wear 5 % over their life where the fleet's did not (``closed_loop.py
--fleet 4 --fault wear``) crossed rough-od's force late in its first edge in nearly every
scenario (708 crossings in 90 inside machines; the catalogue start, ``ω`` 0 ± 10 %, none). At
``σ_ω`` 0.5 % nothing crosses at that wear and 2 crossings at twice it; at 1 % (kept) nothing
at either, for 0.010 of MRR after the third part on a clean fleet (200 scenarios).

**An operation's offset.** Two operations of one insert on one machine (VPGR3305 grooving
at 190 m/min and contouring at 110 m/min) need not follow one law to the per cent: summed as
one, the few per cent between their ``ln Y`` could be explained only by the exponents, and a
fleet whose laws bent each its own way taught a new machine a feed exponent of 0.61 ± 0.04
for a true 1.04 (``closed_loop.py --fleet 4 --fleet-fault curvature``, seed 97: finish-
contour's roughness crossed at parts 4-6, which the catalogue start never did). Each
operation's evidence is first integrated over its own ``γ`` (:func:`of_operation`), and a new
plan's operation has its own ``γ``: its ``ln K`` variance is ``σ_b^2 + σ_o^2`` over the
fleet's. At ``σ_o`` 2 % nothing crosses there after the first part; a clean fleet loses 0.004
of MRR at the first part and nothing from the second (200 scenarios).

**The operations' spread.** ``σ_o`` is learned as ``σ_b`` is, where the fleet shows it: on
each machine that ran the tool in two operations or more (two plans, or one plan's grooving
and contouring), the operations' ``ln Y`` are compared where they pin it best, and their
DerSimonian-Laird ``τ̂²`` is pooled over the machines with the default 2 % held as
``ν_0`` operations' worth (:func:`.spread.operation_estimates`, :func:`.spread.pooled`).
It matters most to
a new plan on a machine the fleet knows, whose own readings leave its operation's ``γ`` the
whole of its first part's uncertainty: with operations 6 % apart (``closed_loop.py --fleet 4
--operation-spread 0.06 --new-plan-on known``, 100 scenarios) the fixed 2 % crossed the
shared insert's roughness at 30 first parts, the learned spread at 8 (the catalogue 4). A tool
each machine ran in one operation only says nothing of it itself, and takes what the plan's
other tools show (below).

**The fleet's belief.** Machine ``m``'s evidence ``(J_m, h_m)`` (:mod:`.evidence`, summed
over its operations on the tool, each integrated over its ``γ``) is about ``θ_m``;
integrating ``u_m`` out gives its evidence about ``θ`` (Woodbury's identity in ``L``, so that
``D`` and ``J_m`` may be singular):

.. math:: J'_m = (J_m^{-1} + D)^{-1} = J_m − J_m L (I + L^\mathsf{T} J_m L)^{-1} L^\mathsf{T} J_m,
   \quad h'_m = h_m − J_m L (I + L^\mathsf{T} J_m L)^{-1} L^\mathsf{T} h_m

so a machine, however many parts it made, says at most ``σ_b`` about the fleet's ``ln K`` and
``σ_e e_i`` about each exponent. With the catalogue prior ``(P_0, m_0)``:
``P = P_0 + Σ J'_m``, ``μ = P^{-1}(P_0 m_0 + Σ h'_m)``. A new machine's ``θ`` is
``N(μ, P^{-1} + D)``, and its operation's ``ln K`` has ``σ_o^2`` more.

**The spread.** Each machine's evidence gives its ``ln Y`` at a reference point,
``y_m ± √v_m``, with the catalogue's exponents but not its ``ln K`` (the comparison,
below). The point is where the machines' readings pin ``ln Y`` best, ``φ = (1, x, 0)``
minimising ``Σ_m φ^\mathsf{T} C_m φ`` (:func:`.spread.best_determined`): at the centre of
the bounds, where machines that learned near their optima never cut, every ``v_m`` holds
the exponents' uncertainty (10 % and more), the machines' differences drown in it and the
estimate is 0 whatever they are. DerSimonian and Laird's moment estimate [2]_ of the spread
between them, ``τ̂²``, is pooled with a default ``σ_0`` held as ``ν_0`` machines' worth of
evidence (the scaled inverse-χ² prior of a normal variance, [1]_ §2.6):

.. math:: σ_b^2 = \frac{ν_0 σ_0^2 + (M − 1) τ̂^2}{ν_0 + M − 1}

never zero, the default until machines disagree, and the machines' own spread as they
accumulate (:data:`DEFAULT_SPREAD`, :data:`SPREAD_WEIGHT`: ``benchmarks/closed_loop.py
--fleet``).

**The comparison.** DerSimonian and Laird's ``y_m`` are each machine's own estimate; a
posterior that the catalogue's ``ln K`` had pulled toward one value holds their differences
times ``J/(J + P_0)`` and ``τ̂²`` far under them where a machine's ``ln K`` is known to no
better than the catalogue's (an operation's offset ``σ_o`` of 10 % caps it at 10 %). So
each machine is compared from its evidence with a prior flat in ``ln K`` given the exponents
(the exponents' marginal, :func:`.spread.intercept_free`): three machines 20 % apart, each known to
10 %, a catalogue's ``ln K`` to 10 %, gave ``τ̂`` 7 % pulled and 17 % so. Evidence that
does not pin its ``ln Y`` (a plan with no reading) is left out of the comparison.

**A plan's tools.** Three machines give one tool's quantity 2 degrees of freedom, so held
against the default's 2 its spread stays near the default's share whatever the machines
show: for machines 1 % apart it was 3.54 %, and the first part ran at 0.883 of the oracle
where a prior that knew the 1 % ran at 0.962. The machines differ for every insert they
hold (their spindles, their rigidity, their measuring chains), so the new plan's other
tools and quantities say what this one's spread is likely to be: each tool and quantity's
``σ_0`` is the default pooled with the *other* tools' and quantities' estimates by their
degrees of freedom (the moderated variance of an empirical-Bayes linear model, Smyth [4]_,
with its prior's degrees of freedom fixed at ``ν_0``; leaving the tool's own out counts
its evidence once), and its own estimates then pool with that ``σ_0`` as above. They may
raise it, never lower it: an estimate of a variance on 2 degrees of freedom is under half
the truth in 2 draws of 5 (``χ²_2 < 1``), and pooled below the others' it put a true 3 % at
2.0 % in one fleet of twenty. The same holds for
``σ_o``. A plan of one tool and quantity, or whose other tools have no evidence, keeps the
default alone, as before (:func:`supervisor.fleet.prior.fleet_priors`). With operations 6 %
apart (``--operation-spread 0.06 --new-plan-on known``, 100 scenarios) the tools each
machine ran once had kept ``σ_o`` at 2 %, and their first parts crossed 34 limits; with the
inserts run twice speaking for them, 20, the catalogue start's. What this assumes,
that the machines differ alike for each insert, was tested where it does not hold
(``closed_loop.py --fleet 4 --spread-mix 0.5``: each tool and quantity's spread drawn
apart, 300 scenarios): first parts inside the spread crossed 14 limits, against 12 with
each tool alone and 11 from the catalogue; the figures are in docs/benchmarks.md.

References
----------
.. [1] Gelman et al., Bayesian Data Analysis, 3rd ed.: §2.6 (scaled inverse-χ² prior of a
   normal variance), §5.4-5.5 (the hierarchical normal model; the group means' posterior).
.. [2] DerSimonian & Laird (1986), "Meta-analysis in clinical trials", Controlled Clinical
   Trials 7(3), 177-188.
.. [3] Gelman & Hill, Data Analysis Using Regression and Multilevel/Hierarchical Models
   (2007), §13.1 (varying intercepts and slopes).
.. [4] Smyth (2004), "Linear models and empirical Bayes methods for assessing differential
   expression in microarray experiments", Statistical Applications in Genetics and
   Molecular Biology 3(1), Article 3: each gene's variance moderated toward a prior value
   estimated from all genes, ``s̃² = (d_0 s_0² + d s²)/(d_0 + d)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from supervisor.fleet.evidence import Evidence

#: ``σ_0``: the default between-machine spread of ``ln K`` [-], 5 %: the machines' share of a
#: tool's scatter (benchmarks/closed_loop.py --fleet; the module docstring).
DEFAULT_SPREAD = 0.05
#: ``ν_0``: the default spread counts as this many machines' evidence.
SPREAD_WEIGHT = 2.0
#: ``σ_e``: the between-machine spread of each exponent, relative to the catalogue's [-]
#: (the module docstring; benchmarks/closed_loop.py --fleet 4 --fault curvature).
DEFAULT_EXPONENT_SPREAD = 0.02
#: ``σ_ω``: the between-machine spread of a wearing quantity's rise over an edge's life, in
#: ``ln`` [-] (the module docstring; benchmarks/closed_loop.py --fleet 4 --fault wear).
DEFAULT_EDGE_SPREAD = 0.01
#: ``σ_o``: the default spread of an operation's ``ln K`` about its machine's [-], learned
#: from the fleet's operations where a machine ran two (:func:`.spread.operation_estimates`;
#: the module docstring; benchmarks/closed_loop.py --fleet 4 --fleet-fault curvature).
DEFAULT_OPERATION_SPREAD = 0.02


@dataclass(frozen=True)
class FleetBelief:
    """``θ ~ N(mean, cov)`` of a new machine, the spread ``σ_b`` and what it came from.

    ``law_cov``: the fleet's law's own covariance, ``cov`` without a new machine's ``D``.
    """

    mean: np.ndarray
    cov: np.ndarray
    spread: float
    machines: int
    readings: int
    law_cov: np.ndarray


def between(
    reference: np.ndarray,
    spread: float,
    exponent_scales: np.ndarray,
    edge_spread: float = 0.0,
) -> np.ndarray:
    """``L``, ``D = L L^T``: the between-machine law of ``θ``'s offsets (module docstring).

    ``reference``: ``φ = (1, x_r[, 0])``, the point the machines' exponents pivot about;
    ``exponent_scales``: ``σ_e |e_i|`` of the ``n`` exponents; ``edge_spread``: ``σ_ω`` of a
    wearing quantity's ``ω`` (``θ`` one longer than ``n + 1``).
    """
    n = len(exponent_scales)
    factor = np.zeros((len(reference), len(reference)))
    factor[0, 0] = spread
    factor[1 : n + 1, 1 : n + 1] = np.diag(exponent_scales)
    factor[0, 1 : n + 1] = -reference[1 : n + 1] * exponent_scales
    if len(reference) > n + 1:
        factor[n + 1, n + 1] = edge_spread
    return factor


def marginal(evidence: Evidence, factor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(J', h')``: a machine's evidence about the fleet's ``θ`` (module docstring).

    ``factor``: ``L`` with ``D = L L^T``, the between-machine law of the offsets
    (:func:`between`).
    """
    return _marginals(evidence.information, evidence.vector, factor)


def _marginals(
    information: np.ndarray, vector: np.ndarray, factor: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`marginal` of ``J`` ``(…, k, k)`` and ``h`` ``(…, k)``, stacked or not."""
    js = information @ factor
    inner = np.eye(factor.shape[1]) + factor.T @ js
    j_marginal = information - js @ np.linalg.solve(inner, np.swapaxes(js, -1, -2))
    shifted = js @ np.linalg.solve(inner, (factor.T @ vector[..., np.newaxis]))
    return 0.5 * (j_marginal + np.swapaxes(j_marginal, -1, -2)), vector - shifted[..., 0]


def of_operation(seen: Evidence, spread: float = DEFAULT_OPERATION_SPREAD) -> Evidence:
    """An operation's evidence about its machine's ``θ_m`` (the module docstring).

    Its own ``ln K`` offset ``γ ~ N(0, spread²)`` integrated out: :func:`marginal` with
    the one column ``L = spread e_0`` (``D = L L^T``).
    """
    return summed([seen], spread)


def summed(operations: Sequence[Evidence], op_spread: float) -> Evidence:
    """A machine's evidence: its operations', each integrated over its own offset ``σ_o``.

    The operations go through :func:`marginal` stacked, at once.
    """
    factor = np.zeros((len(operations[0].vector), 1))
    factor[0, 0] = op_spread
    information, vector = _marginals(
        np.array([o.information for o in operations]),
        np.array([o.vector for o in operations]),
        factor,
    )
    first = operations[0]
    if any(o.names != first.names for o in operations):
        raise ValueError(f"evidence over {first.names} summed with evidence over other inputs")
    readings = sum(o.readings for o in operations)
    return Evidence(first.names, information.sum(axis=0), vector.sum(axis=0), readings)


def fleet_belief(
    machines: Sequence[Evidence],
    prior_mean: np.ndarray,
    prior_cov: np.ndarray,
    reference: np.ndarray,
    exponents: int,
    spread: float,
    exponent_spread: float = DEFAULT_EXPONENT_SPREAD,
    edge_spread: float = DEFAULT_EDGE_SPREAD,
) -> FleetBelief:
    """A new machine's ``θ`` from the machines' evidence and the catalogue prior.

    ``reference``: ``φ``, where the machines' ``ln Y`` are compared and their exponents pivot;
    ``exponents``: how many of ``θ``'s parameters after ``ln K`` are exponents (the rest, the
    edge's rise, has no between-machine spread); ``spread``: ``σ_b``
    (:func:`.spread.between_estimate` pooled, :func:`supervisor.fleet.prior.fleet_priors`).
    """
    p0 = np.linalg.inv(prior_cov)
    scales = exponent_spread * np.abs(prior_mean[1 : exponents + 1])
    factor = between(reference, spread, scales, edge_spread)
    information, vector = p0.copy(), p0 @ prior_mean
    for m in machines:
        j, h = marginal(m, factor)
        information, vector = information + j, vector + h
    law_cov = np.linalg.inv(information)
    mean = law_cov @ vector
    cov = law_cov + factor @ factor.T
    cov = 0.5 * (cov + cov.T)
    readings = sum(m.readings for m in machines)
    return FleetBelief(mean, cov, spread, len(machines), readings, 0.5 * (law_cov + law_cov.T))
