r"""What a belief's readings alone say: their information ``(J, h)``, kept beside the belief.

A ``learn`` belief (:mod:`supervisor.rcb.posterior`) is its start times its readings'
likelihood, in information form ``P = P₀ + J``, ``P μ = P₀ μ₀ + h`` (the product of Gaussians
[1]_), until the learner forgets: a change's discount (:func:`supervisor.rcb.learning.discount`)
or the random walk ``τ`` grows the intercept's variance, and ``P − P₀`` is then no longer the
readings' (it is short of what the step took, and indefinite). Three places need the readings'
own: the fleet reads each plan's evidence (:mod:`supervisor.fleet.evidence`), the prior check
weighs them under a fleet prior and a widened one (:mod:`supervisor.rcb.prior_check`), and a
new noise scale re-weighs them (:func:`supervisor.rcb.learning.rescaled`). Until 2026-12-06 all
three read the positive part of ``P − P₀``, whose eigenvectors mix the step's loss in the
intercept with the exponents' evidence (a machine outside the fleet, seed 49 of ``closed_loop.py
--fleet 4 --fleet-fault noise-scale:3``: a feed exponent 1.08 ± 0.07 read as 0.97 from it), and
re-weighing after a step undid part of it (``P₀ + ρ(P − P₀)`` with ``ρ < 1`` gives back
precision the step took).

So a belief keeps ``(J, h)``, at its noise scale, and each update moves it as it moves the belief:

- a reading ``ln y`` at ``φ`` with noise ``σ``: ``J += φφᵀ/σ²``, ``h += φ ln y / σ²``;
- a step of variance ``v`` of the intercept, applied to the readings' own Gaussian (the
  information filter's prediction [2]_, by the Woodbury identity [3]_, which holds where ``J``
  is singular):

  .. math:: J' = J − \frac{J e_0 e_0^\mathsf{T} J}{1/v + J_{00}}, \qquad
     h' = h − \frac{J e_0 \, h_0}{1/v + J_{00}}

  so the readings before a change still say what they said of the exponents, and of the
  intercept what the step leaves;
- the intercept moved by ``d`` (a change other operations showed, a raise to a reading):
  ``h += J e₀ d``, the readings' own mean moved as the belief's;
- the noise scale ``λ → λ'``: ``J`` and ``h`` times ``ρ = λ/λ'``.

The start's part ``P − J`` is left as it is by a reading and a re-weighing, and a step keeps it
positive semidefinite (the step's map is monotone in ``P``), so re-weighing the readings,
``P' = P + (ρ − 1) J``, never gives back what a step took. A belief stored before 2026-12-06
holds no ``(J, h)``: its readings are read as before, the positive part of ``P − P₀``
(:func:`~supervisor.rcb.information_form.positive_part`).

References
----------
.. [1] Bishop, Pattern Recognition and Machine Learning (2006), §2.3.3.
.. [2] Thrun, Burgard & Fox, Probabilistic Robotics (2005), §3.5.1 (the information filter).
.. [3] Golub & Van Loan, Matrix Computations, 4th ed. (2013), §2.1.4.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from supervisor.rcb.information_form import positive_part, step, tuples
from supervisor.rcb.posterior import Posterior


def stepped(belief: Posterior, variance: float) -> Posterior:
    """``belief`` after a random-walk step ``variance`` of its intercept: old evidence weighs less.

    ``Σ₀₀ + v``, and the readings' ``(J, h)`` with it (module docstring).
    """
    cov = [list(row) for row in belief.cov]
    cov[0][0] += variance
    if belief.readings_information is None or belief.readings_vector is None:
        return replace(belief, cov=tuple(tuple(row) for row in cov))
    j, h = step(np.array(belief.readings_information), np.array(belief.readings_vector), variance)
    readings, vector = tuples(j, h)
    return replace(
        belief,
        cov=tuple(tuple(row) for row in cov),
        readings_information=readings,
        readings_vector=vector,
    )


def shifted(belief: Posterior, shift: float) -> Posterior:
    """``belief`` with its intercept moved by ``shift`` [ln], its readings' own mean with it.

    ``h + J e₀ shift``: a change other operations showed, or a raise to a reading
    (:mod:`supervisor.rcb.learning`), moves what the readings say of ``ln K`` as it moves the
    belief; left where it was, re-weighing the readings pulled the belief back towards the
    level before the change, and the exponents took up the difference (``closed_loop.py
    --fault step:15:1.12``, seed 32: finish-od's feed exponent 1.13 → 1.08 over 10 parts,
    roughness crossed at parts 24-29).
    """
    mean = (belief.mean[0] + shift, *belief.mean[1:])
    if belief.readings_information is None or belief.readings_vector is None:
        return replace(belief, mean=mean)
    column = np.array(belief.readings_information)[:, 0]
    vector = tuple(float(v) for v in np.array(belief.readings_vector) + column * shift)
    return replace(belief, mean=mean, readings_vector=vector)


def reweighed(belief: Posterior, rho: float) -> Posterior | None:
    """``belief`` with its readings weighing ``rho`` times as much: ``P + (ρ − 1) J``.

    None: ``belief`` holds no ``(J, h)`` (stored before they were kept), or the precision is
    not positive definite (round-off of a belief that knows its law nearly exactly).
    """
    if belief.readings_information is None or belief.readings_vector is None:
        return None
    j, h = np.array(belief.readings_information), np.array(belief.readings_vector)
    precision = belief.precision + (rho - 1.0) * j
    precision = 0.5 * (precision + precision.T)
    if float(np.linalg.eigvalsh(precision)[0]) <= 0.0:
        return None
    cov = np.linalg.inv(precision)
    cov = 0.5 * (cov + cov.T)
    mean = cov @ (belief.precision @ belief.mean_array + (rho - 1.0) * h)
    readings, vector = tuples(rho * j, rho * h)
    return replace(
        belief,
        mean=tuple(float(m) for m in mean),
        cov=tuple(tuple(float(v) for v in row) for row in cov),
        readings_information=readings,
        readings_vector=vector,
    )


def readings_of(belief: Posterior, start: Posterior) -> tuple[np.ndarray, np.ndarray]:
    """The readings' ``(J, h)`` of ``belief``, which started from ``start``.

    Its own where it keeps them; else (stored before 2026-12-06) the positive part of
    ``P − P₀``.
    """
    if belief.readings_information is not None and belief.readings_vector is not None:
        return np.array(belief.readings_information), np.array(belief.readings_vector)
    return positive_part(
        belief.precision - start.precision,
        belief.precision @ belief.mean_array - start.precision @ start.mean_array,
    )
