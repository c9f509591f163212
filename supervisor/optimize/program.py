"""The data of a log-linear program: its rows, cone terms and bounds (no solver objects).

A leaf of :mod:`supervisor.optimize`: the formulation builds these, the solvers
(:mod:`.highs_lp`, :mod:`.socp`, :mod:`supervisor.optimize.productivity`) read them, and it
imports nothing from either side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.monomial import Monomial
from models.quantities import Sense
from supervisor.inputs.objectives import Objective


@dataclass(frozen=True, eq=False)
class ConeTerm:
    """``z ‖G x + h‖``, the spread a learned row adds to its linear part.

    The cone of a learned model (:mod:`supervisor.rcb.posterior`).

    ``G`` and ``h`` are arrays (not to be written to); a term is equal only to itself.
    """

    G: np.ndarray
    h: np.ndarray
    z: float


@dataclass(frozen=True)
class Row:
    """One linear constraint ``coefficients · x <= rhs`` on ``x = ln(parameters)``.

    ``name`` is the quantity it limits, ``limit`` the limit in that quantity's unit and
    ``sense`` whether it is a maximum or a minimum. ``given_as`` names the limit as the
    engineer wrote it, which is ``limit / scale`` (``parts_per_edge`` is tool life / volume).
    ``check`` is the bounded quantity of a row that no model predicts (Borangiu's domain), for
    the re-check of an optimum. ``cone``: a learned row is ``coefficients · x + z ‖G x + h‖
    <= rhs``, a second-order cone (:mod:`supervisor.rcb.posterior`).
    """

    name: str
    coefficients: tuple[float, ...]
    rhs: float
    limit: float
    sense: Sense
    given_as: str
    scale: float = 1.0
    check: Monomial | None = None
    cone: ConeTerm | None = None


@dataclass(frozen=True)
class LogLinearProgram:
    """Data of one operation's log-linear program (no solver objects).

    ``objective`` is the ``ln(MRR)`` gradient; ``cost`` the terms of ``J`` in ``parameters``
    (empty without cost data) and ``goal`` which of the two the optimum is for. ``start``: a
    point near the optimum (the last one), where cone rows get their first cuts.
    """

    operation: str
    parameters: tuple[str, ...]
    objective: tuple[float, ...]
    rows: tuple[Row, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    cost: tuple[Monomial, ...] = ()
    goal: Objective = "mrr"
    start: tuple[float, ...] | None = None
