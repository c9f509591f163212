r"""Empirical power-law models with an uncertainty band on K, and their first-order propagation.

.. math::

    Y = K \prod_i x_i^{e_i}, \qquad
    \left(\frac{\Delta Y}{Y}\right)^2 = \left(\frac{\Delta K}{K}\right)^2
        + \sum_i \left(e_i \frac{\Delta x_i}{x_i}\right)^2

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST), Eqs. 5, 6 and 8 (the models) and
   Eqs. 7 and 9 (the propagation). Eqs. 7 and 9 print ``a (Δd/d)^2``; the first-order law is
   ``(a Δd/d)^2``, as used here.
.. [2] JCGM 100:2008 (GUM), Eq. 10, law of propagation of uncertainty for uncorrelated inputs;
   Taylor & Kuyatt, NIST Technical Note 1297 (1994).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from models.errors import ModelDomainError
from models.monomial import Monomial
from models.quantities import MODEL_QUANTITIES, Quantity


@dataclass(frozen=True)
class Prediction:
    """A predicted value and its band ``±band`` (same unit as the value)."""

    value: float
    band: float

    @property
    def upper(self) -> float:
        """Upper edge of the band, ``value + band``."""
        return self.value + self.band

    @property
    def lower(self) -> float:
        """Lower edge of the band, ``value − band``."""
        return self.value - self.band

    def scaled(self, factor: float) -> Prediction:
        """Value and band times ``factor`` (> 0): a quantity proportional to this one."""
        return Prediction(self.value * factor, self.band * factor)


@dataclass(frozen=True)
class PowerLawModel:
    """``Y = K · Π x_i^e_i`` with an uncertainty band ``±dK`` on K.

    Parameters
    ----------
    quantity : str
        Name of the predicted quantity, one of :data:`models.quantities.MODEL_QUANTITIES`.
    K : float
        Coefficient [unit of the quantity].
    dK : float
        Half-width of the band on K [unit of the quantity], ``dK >= 0``.
    exponents : Mapping[str, float]
        Exponent of each input variable (``depth_mm``, ``feed_mm_rev``, ...).
    source : str
        Where the model comes from (paper, test series, fit).
    reference : str
        Table or equation in the source.
    exponent_stderr : Mapping[str, float]
        Standard errors of fitted exponents (``rcb fit`` prints them), for those it has;
        the ``learn`` strategy takes them as its prior's spread.
    """

    quantity: str
    K: float
    dK: float
    exponents: Mapping[str, float] = field(default_factory=dict)
    source: str = ""
    reference: str = ""
    exponent_stderr: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.quantity not in MODEL_QUANTITIES:
            known = ", ".join(MODEL_QUANTITIES)
            raise ModelDomainError("quantity", self.quantity, f"unknown; known: {known}")
        if not (math.isfinite(self.K) and self.K > 0):
            raise ModelDomainError(f"{self.quantity}.K", self.K, "must be a positive number")
        if not (math.isfinite(self.dK) and self.dK >= 0):
            raise ModelDomainError(f"{self.quantity}.dK", self.dK, "must be a number >= 0")
        for name, exponent in self.exponents.items():
            if not math.isfinite(exponent):
                raise ModelDomainError(
                    f"{self.quantity}.exponents.{name}", exponent, "must be a finite number"
                )
        for name, error in self.exponent_stderr.items():
            where = f"{self.quantity}.exponent_stderr.{name}"
            if name not in self.exponents:
                raise ModelDomainError(where, error, "names no exponent of the model")
            if not (math.isfinite(error) and error >= 0):
                raise ModelDomainError(where, error, "must be a number >= 0")

    @property
    def info(self) -> Quantity:
        """The quantity this model predicts."""
        return MODEL_QUANTITIES[self.quantity]

    @property
    def monomial(self) -> Monomial:
        """The nominal model as a monomial ``K · Π x_i^e_i``."""
        return Monomial(self.K, self.exponents)

    def relative_band(self, rel_uncertainty: Mapping[str, float] | None = None) -> float:
        """Relative band ``ΔY/Y`` of this model (see :func:`relative_band`)."""
        return relative_band(self.dK / self.K, self.exponents, rel_uncertainty or {})

    def predict(
        self, point: Mapping[str, float], rel_uncertainty: Mapping[str, float] | None = None
    ) -> Prediction:
        """Predicted value and band at ``point`` (see :func:`predict`)."""
        return predict(self, point, rel_uncertainty)


def relative_band(
    dK_over_K: float, exponents: Mapping[str, float], rel_uncertainty: Mapping[str, float]
) -> float:
    r"""First-order relative band of a power law.

    .. math:: \frac{\Delta Y}{Y} = \sqrt{\left(\frac{\Delta K}{K}\right)^2
              + \sum_i \left(e_i \frac{\Delta x_i}{x_i}\right)^2}

    Parameters
    ----------
    dK_over_K : float
        Relative band of the coefficient [-].
    exponents : Mapping[str, float]
        Exponent of each input [-].
    rel_uncertainty : Mapping[str, float]
        Relative uncertainty ``Δx_i/x_i`` of each input that has one [-]; inputs not named
        are taken as exact.

    Returns
    -------
    float
        ``ΔY/Y`` [-].

    References
    ----------
    .. [1] Ivester & Heigel, Eqs. 7 and 9, with the exponent inside the square
       (the paper's ``a (Δd/d)^2`` is a misprint); GUM (JCGM 100:2008) Eq. 10.
    """
    total = dK_over_K**2
    for name, rel in rel_uncertainty.items():
        if not (math.isfinite(rel) and rel >= 0):
            raise ModelDomainError(f"rel_uncertainty.{name}", rel, "must be a number >= 0")
        total += (exponents.get(name, 0.0) * rel) ** 2
    return math.sqrt(total)


def predict(
    model: PowerLawModel,
    point: Mapping[str, float],
    rel_uncertainty: Mapping[str, float] | None = None,
) -> Prediction:
    """Predict ``Y`` and its band ``ΔY`` at a point.

    Parameters
    ----------
    model : PowerLawModel
        The model.
    point : Mapping[str, float]
        Value of every input variable of the model, in the unit its name carries.
    rel_uncertainty : Mapping[str, float], optional
        Relative uncertainties ``Δx_i/x_i`` of the inputs [-].

    Returns
    -------
    Prediction
        ``Y = K Π x_i^e_i`` (Ivester & Heigel Eqs. 5, 6, 8) and ``ΔY`` (Eqs. 7, 9 corrected).
    """
    value = model.monomial.evaluate(point)
    return Prediction(value, value * model.relative_band(rel_uncertainty))
