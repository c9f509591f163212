"""A chain that turns noisier is told by a CUSUM of its readings' squared noise, and its old
evidence is cut back at once (supervisor/rcb/noise_watch.py).

The memory alone (``noise.NOISE_MEMORY``) left ``noise-step:500:3`` 6 crossings in 30
scenarios x 1000 parts, while the chain's evidence turned over (docs/benchmarks.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_noise_memory import _readings

from supervisor.rcb import monitor_state as ms
from supervisor.rcb import noise_watch as nw


def test_the_log_likelihood_ratio_of_a_doubled_variance():
    # ℓ(x) = ½(1 − 1/2) x − ½ ln 2: negative on a reading of the believed variance (x = 1),
    # positive on average on a chain 3x noisier (E x = 9): 9/4 − 0.3466 = 1.903
    assert nw.llr(1.0) == pytest.approx(0.25 - 0.5 * math.log(2.0), rel=1e-12)
    assert nw.llr(9.0) == pytest.approx(1.9034264097200273, rel=1e-12)
    assert nw.llr(0.0) < nw.llr(1.0) < 0.0 < nw.llr(2.0)


def _chain(llrs: list[float], alarm: float = 0.0) -> dict[tuple[str, str], ms.Monitor]:
    return {
        (f"op{i}", "force_N"): ms.Monitor(
            chain_shape=11.5, chain_rate=13.0, noise_llr=v, chain_alarm=alarm
        )
        for i, v in enumerate(llrs)
    }


def test_the_chain_sums_its_operations_and_keeps_the_sum_in_each():
    monitors = _chain([1.0, 2.5, -0.5], alarm=3.0)
    monitors[("op0", "roughness_um")] = ms.Monitor(noise_llr=7.0)  # another chain: not read
    nw.watched(monitors, ["force_N"])
    force = [v for k, v in monitors.items() if k[1] == "force_N"]
    assert [v.chain_alarm for v in force] == [6.0, 6.0, 6.0]  # 3 + 1 + 2.5 − 0.5
    assert [v.noise_llr for v in force] == [0.0, 0.0, 0.0]  # counted once
    assert [v.chain_shape for v in force] == [11.5] * 3  # under the threshold: kept
    assert monitors[("op0", "roughness_um")].noise_llr == 7.0
    quiet = _chain([-0.4, -0.3], alarm=0.5)
    nw.watched(quiet, ["force_N"])
    assert {v.chain_alarm for v in quiet.values()} == {0.0}  # a CUSUM stops at 0


def test_an_alarm_cuts_every_operations_evidence_to_a_quarter_keeping_its_mean():
    monitors = _chain([3.0, 3.0], alarm=2.5)  # 8.5 > ALARM_H
    nw.watched(monitors, ["force_N"])
    for monitor in monitors.values():
        # a − a0 = 10 -> 2.5, b − b0 = 12 -> 3: the evidence's mean 12/10 kept
        assert monitor.chain_shape == pytest.approx(1.5 + 2.5)
        assert monitor.chain_rate == pytest.approx(1.0 + 3.0)
        assert (monitor.chain_alarm, monitor.noise_llr) == (0.0, 0.0)


def _parts(monitor: ms.Monitor, rng, count: int, scale: float, watch: bool) -> ms.Monitor:
    """``count`` parts, each one reading of one operation, the chain watched after each."""
    for _ in range(count):
        monitor = _readings(monitor, rng, 1, scale)
        if watch:
            monitors = {("op", "force_N"): monitor}
            nw.watched(monitors, ["force_N"])
            monitor = monitors[("op", "force_N")]
    return monitor


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_chain_three_times_noisier_after_500_quiet_parts_is_believed_sooner(seed):
    quiet = _parts(ms.Monitor(), np.random.default_rng(seed), 500, 1.0, watch=True)
    assert quiet.chain_noise.prudent_scale < 1.45  # 500 parts: no alarm cut it back
    watched, memory = (
        _parts(quiet, np.random.default_rng(100 + seed), 25, 3.0, watch=w) for w in (True, False)
    )
    # the memory alone after 25 readings: 1 − 0.95^25 = 72 % of the evidence is new
    assert watched.chain_noise.prudent_scale > memory.chain_noise.prudent_scale
    assert watched.chain_noise.prudent_scale > 2.6


def test_a_quiet_chain_raises_no_alarm_in_3000_parts():
    monitor, rng, cut = ms.Monitor(), np.random.default_rng(7), 0
    for _ in range(3000):
        before = monitor.chain_shape
        monitor = _parts(monitor, rng, 1, 1.0, watch=True)
        cut += monitor.chain_shape < 0.5 * before
    assert cut == 0
    assert monitor.chain_noise.prudent_scale < 1.45
