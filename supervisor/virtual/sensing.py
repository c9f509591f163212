"""A virtual spindle sensor: the reading a calibrated machine shows for a true cutting force.

The virtual machine (:mod:`supervisor.virtual.simulate`) knows the true force; a shop measures the
spindle current (Kim & Jeon §6.2.3) or the spindle load (Ivester & Heigel Eqs. 1-3) and
converts it with the machine's calibration (:func:`models.sensors.to_force`). The reading is
the calibration run backwards, plus the instrument's noise, so that the conversion the
supervisor applies gives the true force back up to that noise.

Every supported calibration is affine in the reading at a given operating point (speed, feed
rate, diameter), ``F = F(0) + s·r``, so two conversions fix the line and its inverse exactly.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from models.errors import InputError
from models.sensors import Calibration, to_force
from models.sensors.convert import converts

#: Readings used to fix the affine line (large enough that every calibration gives F >= 0).
_PROBES = (1.0e3, 2.0e3)


def reading_for_force(
    calibration: Calibration, force_N: float, context: Mapping[str, object]
) -> float:
    """The spindle reading whose conversion by ``calibration`` is ``force_N``.

    Parameters
    ----------
    calibration : Calibration
        A force calibration (``linear_current``, ``linear_current_by_feed`` or
        ``ivester_spindle_load``).
    force_N : float
        The true cutting force [N].
    context : Mapping[str, object]
        What the conversion needs at the operating point (spindle speed, feed rate, diameter),
        as :func:`models.sensors.to_force` takes it.

    Returns
    -------
    float
        The reading [A or V, the calibration's raw quantity], ``>= 0``.
    """
    raw = converts(calibration)
    if raw is None:
        raise InputError("calibration.kind", calibration.kind, "does not convert to force")
    r1, r2 = _PROBES
    f1 = to_force(calibration, raw, r1, 0.0, context).value
    f2 = to_force(calibration, raw, r2, 0.0, context).value
    reading = r1 + (force_N - f1) * (r2 - r1) / (f2 - f1)
    return max(reading, 0.0)


def noisy_reading(
    calibration: Calibration,
    force_N: float,
    context: Mapping[str, object],
    expanded_uncertainty: float,
    rng: np.random.Generator,
) -> float:
    """:func:`reading_for_force` plus Gaussian noise ``N(0, (U/2)²)`` (GUM 6.2-6.3), ``>= 0``.

    Parameters
    ----------
    calibration, force_N, context
        As :func:`reading_for_force`.
    expanded_uncertainty : float
        The instrument's expanded (≈2σ) uncertainty ``U`` [unit of the reading].
    rng : numpy.random.Generator
        Source of the noise.
    """
    reading = reading_for_force(calibration, force_N, context)
    return max(reading + 0.5 * expanded_uncertainty * float(rng.standard_normal()), 0.0)
