"""A band grown to cover a reading is run to its edge at the limit: it covers the reading at
more than the paper's ``y + u`` (``supervisor/rcb/law.py``, docs/concepts/rcb.md).

Found at machines 20 % apart (``closed_loop.py --fleet 4 --fleet-spread 0.2``, seed 113): the
new machine's fleet start ran rough-od at the fleet prior's cone at part 1 (the force prior
vetoed the catalogue band); its roughness read 2.928 ± 0.05 µm where the truth was 2.982, and
the fallback band grew to cover the paper's ``y + u``. The band program took that band to its
edge at the limit, where the truth stood 1.08 u over the reading's cover: 4.004 µm on a 4 µm
limit at part 2, an avoidable crossing. At ``y + P u`` (P = 2.11 before the chain's noise is
known) the band covers it and part 2 runs under the limit; since 2026-12-06 at the margin's
``u + δ``, up to ``y + Q u`` the further the reading lies over its prediction
(test_grown_band_noise.py).
"""

from __future__ import annotations

from pathlib import Path

from supervisor.inputs.plan import load_plan
from supervisor.virtual.fleet_scenario import FleetWorld, simulate_fleet

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")


def test_seed_113_at_a_20_per_cent_spread_crosses_no_limit_after_its_first_part() -> None:
    (trace,) = simulate_fleet(PLAN, range(113, 114), 4, 5, 30, 1, None, FleetWorld(0.2))
    assert not trace.outside
    for start in (trace.fleet, trace.catalogue, trace.known):
        assert [w for w in start.where if w[0] > 1] == []  # part 1 may cross: no reading yet
    # and it ran near the limit: the band's cover costs rough-od little after part 1 (0.969 of
    # its oracle at y + P u, 0.948 at y + Q u: the price of a chain 3 x noisier held)
    assert trace.fleet.op_ratio[1][0] > 0.94
