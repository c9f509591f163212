r"""Whether what a plan learned since a change its monitors counted confirms the change.

A plan's monitors count a change of its process (``regime_change``,
:mod:`supervisor.rcb.monitor`) at a real change, and at the upper CUSUM's false alarms too: on a
steady process one in about 2 600 readings of a quantity, so a plan that reads a dozen
quantities a part counts one every two hundred parts or so. Left out of the fleet whole at
every count, 57 of 90 learning plans were out after 300 steady parts (``benchmarks/
closed_loop.py --fleet 4 --learn-parts 300``, 30 scenarios), the learned spread fell back to
the default's and a new machine's first part slowed from 0.888 to 0.863 of its oracle.

A change is judged :data:`JUDGED_AFTER` parts after the part that counted it. It is
*confirmed* when, for some quantity of the plan, the law learned by then differs from the law
learned before that part by more than :data:`CONFIRM_Z` standard deviations, where the newer is
best determined (where the plan cuts: ``φ = (1, x, 0)``, ``x = −Σ_xx⁻¹ Σ_x0`` of the newer
covariance, a new edge):

.. math:: z = \frac{|φ^T (μ_{now} − μ_{before})|}{\sqrt{φ^T (Σ_{now} + Σ_{before}) φ}}

The two beliefs share the readings before the change, so the sum overstates the variance of
the difference and ``z`` errs towards "not confirmed" (:data:`CONFIRM_Z` gives the figures).
A confirmed change keeps the plan out of the fleet until an engineer accepts it; one not
confirmed is accepted by itself, and the plan counts with everything it learned. Where
nothing was learned before the change there is nothing to compare: confirmed. Judged over a
few parts, not over the plan's life: between beliefs hundreds of parts apart a steady process
read ``z`` up to 8 (its setpoints, its edges and the exponents' small errors move the point
the law is best known at), which would confirm nearly every false alarm.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from supervisor.rcb.posterior import Posterior
from supervisor.rcb.state import RcbState

#: Parts after the part that counted a change its readings are judged at.
JUDGED_AFTER = 5
#: A shift of the learned law past this many standard deviations confirms a change. Measured
#: (``z`` with the sum of variances, which overstates the difference's): the CUSUM's false
#: alarms of a steady virtual fleet read 0.8-1.5 at the end of 30-part runs; a 12 % step of
#: every quantity at part 15, 63-172 at part 30; one quantity 15 % up after 6 parts, 2.8
#: five parts on (2.1 at once; tests/db/test_fleet_changes.py), which 3 would miss.
CONFIRM_Z = 2.5


def shift_z(before: Posterior, now: Posterior) -> float:
    """``z`` of the law's shift from ``before`` to ``now`` where ``now`` is best known."""
    cov = np.array(now.cov)
    phi = np.zeros(len(now.mean))
    phi[0] = 1.0
    n = len(now.names)
    if n:
        phi[1 : n + 1] = -np.linalg.solve(cov[1 : n + 1, 1 : n + 1], cov[1 : n + 1, 0])
    shift = float(phi @ (now.mean_array - before.mean_array))
    variance = float(phi @ (cov + np.array(before.cov)) @ phi)
    return abs(shift) / math.sqrt(max(variance, 1e-300))


@dataclass(frozen=True)
class Shift:
    """The largest shift of a plan's laws since a change: where and how many deviations."""

    #: The quantity it is in: "rough-od force_N".
    where: str
    #: ``z`` (module docstring); None: nothing was learned before the change to compare with.
    z: float | None

    @property
    def confirms(self) -> bool:
        """Whether it confirms the change (:data:`CONFIRM_Z`; nothing to compare with: yes)."""
        return self.z is None or self.z > CONFIRM_Z


#: A plan's beliefs per (operation, quantity), as :attr:`RcbState.posterior` keeps them.
Beliefs = Mapping[tuple[str, str], Posterior | None]


def largest_shift(before: Beliefs, now: Beliefs) -> Shift | None:
    """The largest shift of each quantity's law ``now`` from ``before`` the change.

    Named "operation quantity". None: nothing learned since, so no evidence either way. A
    quantity with nothing learned before the change to compare with comes first, with no ``z``.
    """
    largest: Shift | None = None
    for key, belief in now.items():
        if belief is None:
            continue
        where, old = " ".join(key), before.get(key)
        if old is None or len(old.mean) != len(belief.mean):
            return Shift(where, None)
        z = shift_z(old, belief)
        if largest is None or (largest.z is not None and z > largest.z):
            largest = Shift(where, z)
    return largest


def confirmed(before: Beliefs, now: Beliefs) -> bool:
    """Whether the plan's beliefs ``now`` confirm a change counted after ``before``."""
    shift = largest_shift(before, now)
    return shift is not None and shift.confirms


def counted(state: RcbState) -> int:
    """The changes of its process a plan's monitors counted, over all its quantities."""
    return sum(m.changes for m in state.monitors.values())


def opens_change(before: RcbState, after: RcbState, accepted: int) -> bool:
    """Whether the report from ``before`` to ``after`` counted a change beyond ``accepted``."""
    return counted(after) > max(counted(before), accepted)
