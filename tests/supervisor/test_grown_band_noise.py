"""A band grown by a reading far over its prediction covers it at its chain's noise bound,
``y + Q u`` (``supervisor/rcb/law.py``: the margin's ``u + δ`` up to ``Q u``; docs/concepts/rcb.md).

Found at machines 20 % apart under a chain 3 x noisier than it says (``closed_loop.py --fleet
4 --fleet-spread 0.2 --fault noise-scale:3``, seed 16): the new machine's catalogue start ran
rough-od at the catalogue band at part 1 and crossed its 2000 N force limit (truth 2022 N);
the reading, 2014 ± 3 N, was 2.7 u under the truth (1.8 of the chain's true sd). The band
grew to cover ``y + P u`` (P = 2.11 before the chain's noise is known), 2020 N, and the band
program ran that edge at the limit: 2001 N at part 2, an avoidable crossing. The reading lay
49 u over its prediction (1868 N); the chain's bound ``Q`` (3.15 before any reading), which a
change is already read at, covers it.
"""

from __future__ import annotations

from pathlib import Path

from supervisor.inputs.plan import load_plan
from supervisor.virtual.fault_spec import parse_faults
from supervisor.virtual.fleet_scenario import FleetWorld, simulate_fleet

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")


def test_seed_16_under_a_chain_3_times_noisier_crosses_no_limit_after_its_first_part() -> None:
    faults = parse_faults(["noise-scale:3"])
    (trace,) = simulate_fleet(PLAN, range(16, 17), 4, 5, 30, 1, faults, FleetWorld(0.2))
    assert not trace.outside
    # part 1 crosses on every start: the machine's force lies outside the catalogue's band
    assert (1, "rough-od", "force_N") in trace.catalogue.where
    for start in (trace.fleet, trace.catalogue, trace.known):
        assert [w for w in start.where if w[0] > 1] == []  # part 1 may cross: no reading yet
    # and the cover costs rough-od little: its next setpoint is within 2 % of the oracle's
    assert trace.catalogue.op_ratio[1][0] > 0.98
