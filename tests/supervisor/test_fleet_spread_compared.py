"""The machines' spread compared from their readings, not from the catalogue's pull (issue 32).

Each machine's ``ln Y`` is compared from its evidence about ``ln K`` alone, with the prior's
exponents (:func:`supervisor.fleet.spread._at_each`, :mod:`supervisor.fleet.hierarchy`'s "the
comparison"). Worked by hand from DerSimonian & Laird's moment estimate.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from supervisor.fleet.evidence import Evidence
from supervisor.fleet.spread import between_estimate, intercept_free, operation_estimates


def _at(y: float, information: float = 100.0) -> Evidence:
    return Evidence((), np.array([[information]]), np.array([information * y]), 30)


def test_three_machines_20_percent_apart_are_not_pulled_together_by_the_catalogue() -> None:
    """Machines at ``ln Y`` −0.2, 0, 0.2, each known to ``1/100`` (an operation's ``σ_o`` of
    10 %), the catalogue's ``ln K`` known to 10 % (information 100). From the readings:
    ``Q = 100 · 0.08 = 8``, ``scale = 300 − 3 · 100²/300 = 200``, ``τ̂² = (8 − 2)/200 = 0.03``.
    Pulled by the catalogue first (each ``y`` halved, variance 0.005), it was ``Q = 4``,
    ``τ̂² = (4 − 2)/400 = 0.005``: 7 % for machines 20 % apart."""
    machines = [_at(y) for y in (-0.2, 0.0, 0.2)]
    tau2, dof = between_estimate(machines, np.array([0.0]), np.array([[100.0]]), np.ones(1))
    assert (tau2, dof) == (pytest.approx(0.03), 2)


def test_a_plan_with_no_reading_is_not_a_machine_that_agrees() -> None:
    """Two machines at 0 and 0.1 (information 1e4): ``τ̂² = (50 − 1)/10 000 = 0.0049`` on 1
    degree of freedom (test_fleet_prior's worked case). A third plan with no reading (its
    evidence 0) counted as a machine at the prior's ``ln K`` would add a degree of freedom and
    pull ``τ̂²`` down; it is left out."""
    two = [_at(0.0, 1e4), _at(0.1, 1e4)]
    none = Evidence((), np.zeros((1, 1)), np.zeros(1), 0)
    prior = np.array([[100.0]])
    assert between_estimate(two, np.zeros(1), prior, np.ones(1)) == (pytest.approx(0.0049), 1)
    found = between_estimate([*two, none], np.zeros(1), prior, np.ones(1))
    assert found == (pytest.approx(0.0049), 1)


def test_the_prior_keeps_its_exponents_and_drops_ln_K() -> None:
    """A prior ``ln K`` sd 0.1, feed exponent sd 0.05, correlation 0.5: the exponent's
    marginal information is ``1/0.05² = 400``, ``ln K``'s row and column 0."""
    cov = np.array([[0.01, 0.5 * 0.1 * 0.05], [0.5 * 0.1 * 0.05, 0.0025]])
    free = intercept_free(np.linalg.inv(cov))
    np.testing.assert_allclose(free, [[0.0, 0.0], [0.0, 400.0]], atol=1e-9)


def _machine(level: float, points: list[float], sigma2: float) -> Evidence:
    rows = [np.array([1.0, x]) for x in points]
    j = sum(np.outer(r, r) for r in rows) / sigma2
    h = sum(r * (level + 0.8 * r[1]) for r in rows) / sigma2
    return Evidence(("feed",), j, h, len(points))


@settings(max_examples=40, deadline=None)
@given(
    ln_k_sd=st.floats(0.02, 2.0),
    ln_k_mean=st.floats(-3.0, 3.0),
    levels=st.lists(st.floats(-0.3, 0.3), min_size=2, max_size=5),
)
def test_the_spread_does_not_depend_on_the_catalogues_ln_K(
    ln_k_sd: float, ln_k_mean: float, levels: list[float]
) -> None:
    """Invariant: however wide or wherever the catalogue put ``ln K``, machines whose readings
    are the same compare the same (between machines and between a machine's operations)."""
    machines = [_machine(y, [-1.1, -0.9, -0.7], 4e-3) for y in levels]
    reference = np.array([1.0, -0.9])

    def found(sd: float, mean: float) -> tuple[tuple[float, int], list[tuple[float, int]]]:
        prior_mean = np.array([mean, 0.8])
        information = np.linalg.inv(np.diag([sd**2, 0.1**2]))
        between = between_estimate(machines, prior_mean, information, reference)
        return between, operation_estimates([machines], prior_mean, information, 1)

    (tau2, dof), ops = found(ln_k_sd, ln_k_mean)
    (tau2_wide, dof_wide), ops_wide = found(10.0, 0.0)
    assert dof == dof_wide == len(levels) - 1
    assert tau2 == pytest.approx(tau2_wide, rel=1e-6, abs=1e-12)
    assert ops[0][0] == pytest.approx(ops_wide[0][0], rel=1e-6, abs=1e-12)
