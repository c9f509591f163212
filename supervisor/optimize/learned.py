"""What the optimiser needs of a learned model: its robust cone (the ``learn`` strategy's).

:class:`LearnedCone` is the interface; :class:`supervisor.rcb.cone.Cone` implements it.
The optimiser replaces a quantity's band row by the cone row ``a·x + z‖G x + h‖ <= b``
(:class:`supervisor.optimize.program.ConeTerm`) at each edge age the cone holds at, shows the
model the cone stands for at the optimum, and may re-check a kept setpoint at a lower ``z``.
Declared here so that ``optimize`` does not import ``rcb`` (issue 31: no two-way imports
between supervisor folders; rcb builds on the optimiser, not the other way round).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import numpy as np

from models.monomial import Monomial
from models.powerlaw import PowerLawModel


class LearnedCone(Protocol):
    """A learned model's robust constraint ``μ·φ(x) ± z √(φᵀ Σ φ + v_x)``."""

    @property
    def z(self) -> float:
        """The confidence multiplier of the spread [-]."""
        ...

    @property
    def veto_z(self) -> float:
        """The confidence at which the cone vetoes the band program's optimum [-].

        0: at its mean (:func:`supervisor.optimize.optimizer.optimize_operation`).
        """
        ...

    @property
    def edges(self) -> tuple[int, ...]:
        """The edge ages (parts an edge made) the cone is imposed at."""
        ...

    def factor(
        self, params: tuple[str, ...], rel: Mapping[str, float], edge: int = 0
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(G, h)``: the squared spread is ``‖G ln x + h‖²`` over ``params``."""
        ...

    def nominal(self, edge_parts: int) -> Monomial:
        """The mean model at edge age ``edge_parts``, as a monomial (the row's ``a·x``)."""
        ...

    def at_z(self, z: float) -> LearnedCone:
        """The same cone at confidence ``z``."""
        ...

    def shown(self, point: Mapping[str, float], rel: Mapping[str, float]) -> PowerLawModel:
        """The model whose band at ``point`` is the cone's half-width there (every surface)."""
        ...
