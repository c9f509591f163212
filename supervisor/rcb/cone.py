"""The robust constraint of a ``learn`` posterior, and the model every surface shows for it.

:class:`Cone` is ``μ·φ(x) ± z √(φᵀ Σ₊ φ + v_x)`` of a :class:`supervisor.rcb.posterior.Posterior`
(that module's docstring derives it); it is the optimiser's
:class:`supervisor.optimize.learned.LearnedCone`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from models.monomial import Monomial
from models.powerlaw import PowerLawModel
from models.quantities import MODEL_QUANTITIES
from supervisor.rcb.posterior import Posterior

#: The shown models a posterior keeps (a part needs two or three).
_SHOWN_KEPT = 16


@dataclass(frozen=True)
class Cone:
    """The robust constraint of a posterior: ``μ·φ(x) ± z √(φᵀ Σ₊ φ + v_x)``.

    Derived in :mod:`supervisor.rcb.posterior`'s docstring.

    ``drift`` is the random-walk step of the part to come, added to ``Σ``'s intercept.
    ``veto_z``: the confidence at which the cone vetoes the band program's optimum (0: the
    posterior mean; a fleet prior's :attr:`Posterior.band_veto_z`).
    """

    posterior: Posterior
    z: float
    drift: float
    veto_z: float = 0.0

    @property
    def edges(self) -> tuple[int, ...]:
        """The edge ages the cone is imposed at (:attr:`Posterior.edges`)."""
        return self.posterior.edges

    def nominal(self, edge_parts: int) -> Monomial:
        """The posterior mean at edge age ``edge_parts`` as a monomial."""
        return self.posterior.model(edge_parts=edge_parts).monomial

    def at_z(self, z: float) -> Cone:
        """The same cone at confidence ``z``."""
        return replace(self, z=z)

    def shown(self, point: Mapping[str, float], rel: Mapping[str, float]) -> PowerLawModel:
        """:func:`display_model` of this cone at ``point``.

        Kept on the (immutable) posterior: a part's setpoint is shown when it is chosen and
        again when its reading is judged.
        """
        cache: dict[tuple[object, ...], PowerLawModel]
        cache = self.posterior.__dict__.setdefault("_shown", {})
        key = (self.z, self.drift, tuple(point.items()), tuple(rel.items()))
        if key not in cache:
            if len(cache) >= _SHOWN_KEPT:
                cache.clear()
            cache[key] = display_model(self, point, rel)
        return cache[key]

    @property
    def _chol(self) -> np.ndarray:
        """The Cholesky factor of ``Σ₊``, computed once per posterior and drift."""
        return self.posterior.cholesky(self.drift)

    def spread(
        self, point: Mapping[str, float], rel: Mapping[str, float], edge: float = 0
    ) -> float:
        """``√(φᵀ Σ₊ φ + v_x)`` at ``point`` and edge age ``edge``: the sd of ``ln y`` there."""
        root = self._chol.T @ self.posterior.features(point, edge)
        variance = float(root @ root)
        return math.sqrt(variance + self.setpoint_variance(rel))

    def setpoint_variance(self, rel: Mapping[str, float]) -> float:
        """``v_x``: the plan's setpoint uncertainties through the mean exponents, as ``σ²``."""
        exps = dict(zip(self.posterior.names, self.posterior.exponent_means, strict=True))
        return sum((exps.get(n, 0.0) * r / 2.0) ** 2 for n, r in rel.items())

    def edge_log(self, point: Mapping[str, float], rel: Mapping[str, float]) -> float:
        """``ln`` of the guarding edge at ``point``, the worst over the edge's life."""
        mean = np.array(self.posterior.mean)
        sign = 1.0 if MODEL_QUANTITIES[self.posterior.quantity].sense == "max" else -1.0
        values = [
            float(self.posterior.features(point, n) @ mean)
            + sign * self.z * self.spread(point, rel, n)
            for n in self.posterior.edges
        ]
        return max(values) if sign > 0 else min(values)

    def _linear(self, params: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``Lᵀ`` times the map ``ln x ↦ φ``: ``(G, h₀, Lᵀe_n)``, made once per cone."""
        cache: dict[tuple[str, ...], tuple[np.ndarray, np.ndarray, np.ndarray]]
        cache = self.__dict__.setdefault("_linear_parts", {})
        if params not in cache:
            chol_t = self._chol.T
            selector = np.zeros((len(chol_t), len(params)))
            offset = np.zeros(len(chol_t))
            offset[0] = 1.0
            names = self.posterior.names
            for i, (name, c) in enumerate(zip(names, self.posterior.center, strict=True)):
                selector[i + 1, params.index(name)] = 1.0
                offset[i + 1] = -c
            cache[params] = (chol_t @ selector, chol_t @ offset, chol_t[:, -1].copy())
        return cache[params]

    def factor(
        self, params: tuple[str, ...], rel: Mapping[str, float], edge: int = 0
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(G, h)``: ``φᵀ Σ₊ φ + v_x = ‖G ln x + h‖²`` over ``params``, at edge age ``edge``."""
        G, h0, per_part = self._linear(params)
        h = h0 + float(edge) * per_part if self.posterior.edge_max else h0
        extra = self.setpoint_variance(rel)
        if extra > 0:
            G = np.vstack([G, np.zeros(len(params))])
            h = np.append(h, math.sqrt(extra))
        return G, h


def display_model(
    cone: Cone, point: Mapping[str, float], rel: Mapping[str, float]
) -> PowerLawModel:
    """The learned model whose band at ``point`` is the cone's half-width there.

    The value is ``exp(μ·φ)`` of a new edge; ``ΔK`` is chosen so that the first-order band at
    ``point`` (with the plan's setpoint uncertainties, :func:`models.powerlaw.relative_band`)
    reaches the cone's guarding edge over the edge's life, so predictions, re-checks and every
    surface show ``ΔY`` at the setpoint as for a band.
    """
    model = cone.posterior.model()
    value = model.predict(point).value
    edge = math.exp(cone.edge_log(point, rel))
    band = abs(edge - value)
    setpoint_part = model.relative_band(rel) ** 2
    dK_over_K = math.sqrt(max((band / value) ** 2 - setpoint_part, 0.0))
    return PowerLawModel(
        model.quantity, model.K, model.K * dK_over_K, model.exponents, model.source, model.reference
    )
