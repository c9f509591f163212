"""The virtual shop floor's faults in the closed loop: avoidable and unavoidable violations, the
oracle under faults, and rcb certify's --fault."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from faults_support import PLAN, READINGS
from numpy.testing import assert_array_equal
from typer.testing import CliRunner

from api.cli.main import app
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start
from supervisor.virtual.bound import clopper_pearson_upper
from supervisor.virtual.certificate import Certificate, ScenarioTrace, digest, summarize
from supervisor.virtual.certify import simulate
from supervisor.virtual.fault_oracle import truth_oracle
from supervisor.virtual.fault_spec import parse_faults
from supervisor.virtual.faults import PartFaults, draw_bends
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.scenario import run_scenario
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN

# --------------------------------------------------------------------------- the closed loop


def test_fault_free_results_are_those_from_before_the_catalogue():
    # digests of the same calls on commit 820403c, the code before the fault catalogue, were
    # aabf515a2a9d and d17dc7599040 (checked when the catalogue landed); issue 27's rules
    # changed what the learner does (1725bcc25ab8 / d17dc7599040, then 4b5d8fd417bc /
    # d17dc7599040 with learn's noise scale per measuring chain at its upper quantile and no
    # noise learned from a drift in progress; then aa85a5387dd2 / d17dc7599040 with learn's
    # chain belief ungated, its noise update taking out the spread at the estimated noise and
    # its posteriors settled at the report's end; then 52fa330aac59 / 03d53e7813d0 with a
    # reading near the limit read at the chain's prudent noise scale, ivester's and bayes's
    # quarantine judged against the last reading, a common change's unread operation moved
    # at the chain's prudent scale; then 3931dbea6d58 / 27cf13f3d1a0 with the margin of a
    # reading over the prediction at the chain's prudent scale and an unread change backing
    # off by its exponent error; then 0162b3ee15d5 / 7369ac20a3e2 with that margin's u rising
    # with the reading's excess over the prediction, u + δ up to P u; then ebfebdef14c9 /
    # b85724fe872d with it up to the chain's bound Q u and a change read at y + Q u; then
    # fa897c612b31 / a9057698ec01 with the chain's noise evidence worth at most 20 readings
    # per operation, noise.NOISE_MEMORY); then 8505a21b0657 / bf5fb4a65576 with a grown band
    # covering its reading at the margin's u + δ up to Q u, at least P u; today's:
    # without a fault, the catalogue changes nothing, and wear:0.05 is --wear-drift 0.05
    assert digest(simulate(PLAN, ["ivester", "learn"], scenarios=3, parts=12)) == "8505a21b0657"
    wear = simulate(PLAN, ["ivester"], scenarios=2, parts=12, seed=4, wear_drift_per_edge_life=0.05)
    assert digest(wear) == "bf5fb4a65576"
    worn = simulate(
        PLAN, ["ivester"], scenarios=2, parts=12, seed=4, faults=parse_faults(["wear:0.05"])
    )
    assert digest(worn) == "bf5fb4a65576"


def test_neutral_faults_leave_the_noise_stream_alone():
    """Faults that change nothing give the fault-free traces: their draws are their own."""
    initial = start(PLAN, RcbSettings(strategy="learn"))
    neutral = parse_faults(["dropout:0", "noise-scale:1", "curvature:0", "step:3:1"])
    a = run_scenario(initial, 2, 8)
    b = run_scenario(initial, 2, 8, faults=neutral)
    for name in ("plan_ratio", "op_ratio", "cycle_min", "violations"):
        assert_array_equal(getattr(a, name), getattr(b, name))
    assert b.unavoidable_at == (1, 3) and a.unavoidable_at == (1,)
    assert [t.value for t in b.tallies] == [0.0, 8.0 * READINGS, 0.0, 6.0]


def test_a_step_changes_the_oracle_from_its_part_on():
    initial = start(PLAN, RcbSettings(strategy="ivester"))
    trace = run_scenario(initial, 5, 8, faults=parse_faults(["step:4:1.12"]))
    # row 3 holds the setpoints of part 4, the first made on the stepped truth
    ((row, cycle),) = trace.oracle_changes
    assert row == 3 and cycle > trace.oracle_cycle_min  # a harder truth is slower to cut
    stepped = truth_oracle(sample_machine(PLAN, 5), PartFaults(step_factor=1.12))
    assert cycle == stepped.cycle_time_min


def _trace(violations, unavoidable_at, parts_made=None) -> ScenarioTrace:
    parts = len(violations)
    return ScenarioTrace(
        seed=0,
        oracle_cycle_min=1.0,
        plan_ratio=np.ones(parts + 1),
        op_ratio=np.ones((parts + 1, 1)),
        cycle_min=np.ones(parts + 1),
        violations=np.array(violations, dtype=np.int64),
        where=(),
        stopped_at=0 if parts_made is None else parts_made,
        stopped_op="",
        parts_made=parts if parts_made is None else parts_made,
        unavoidable_at=unavoidable_at,
    )


def test_unavoidable_and_avoidable_violations_of_a_constructed_trace():
    # parts 1..6; part 1 and part 5 (a step) are unavoidable
    trace = _trace([2, 0, 1, 0, 3, 1], (1, 5))
    assert trace.unavoidable_violations == 5  # 2 at part 1, 3 at part 5
    assert trace.avoidable_violations == 2  # part 3 and part 6
    assert trace.avoidable_violating_parts == 2
    assert trace.avoidable_parts_made == 4  # parts 2, 3, 4, 6
    # stopped after part 4: part 5 was never made
    stopped = _trace([1, 1, 0, 1, 0, 0], (1, 5), parts_made=4)
    assert (stopped.unavoidable_violations, stopped.avoidable_violations) == (1, 2)
    assert (stopped.avoidable_violating_parts, stopped.avoidable_parts_made) == (2, 3)
    certificate = Certificate("p", "ivester", 0, 6, 0.0, (trace, stopped), 0.0)
    summary = summarize(certificate)
    assert (summary.unavoidable_violations, summary.avoidable_violations) == (6, 4)
    assert summary.violations == 10
    assert (summary.avoidable_violating_parts, summary.avoidable_parts_made) == (4, 7)
    assert summary.avoidable_probability_upper_95 == clopper_pearson_upper(4, 7)


# --------------------------------------------------------------------------- the oracle


def _feasible(machine, setpoints, faults) -> bool:
    return not run_part(machine, setpoints, np.random.default_rng(0), faults=faults).violations


@pytest.mark.parametrize("seed", [0, 3, 8])
def test_the_curved_oracle_meets_every_true_limit_and_beats_the_power_law_point(seed):
    machine = sample_machine(PLAN, seed)
    truth = PartFaults(bends=draw_bends(machine, seed, 0.06))
    curved = truth_oracle(machine, truth)
    best = {op.name: op.setpoint for op in curved.operations}
    assert _feasible(machine, best, truth)
    power_law = truth_oracle(machine)
    params = ("depth_mm", "feed_mm_rev", "speed_m_min")
    for op, fast, plain in zip(
        PLAN.operations, curved.operations, power_law.operations, strict=True
    ):
        low = np.log([op.bounds[p][0] for p in params])
        x = np.log([plain.setpoint[p] for p in params])

        def point(lam, low=low, x=x, op=op):
            return {**best, op.name: dict(zip(params, np.exp(low + lam * (x - low)), strict=True))}

        assert _feasible(machine, point(0.0), truth)  # the slowest corner
        lo, hi = 0.0, 1.0  # the power-law oracle pulled back along ln x until the truth holds
        if not _feasible(machine, point(1.0), truth):
            for _ in range(50):
                mid = (lo + hi) / 2
                lo, hi = (mid, hi) if _feasible(machine, point(mid), truth) else (lo, mid)
        else:
            lo = 1.0
        rate = math.prod(point(lo)[op.name].values())  # turning MRR = d·f·v [cm³/min]
        assert fast.mrr_cm3_min >= rate * (1 - 1e-9), op.name


# --------------------------------------------------------------------------- rcb certify


def _invoke(args):
    return CliRunner().invoke(app, ["certify", *map(str, args)])


def test_cli_json_with_a_fault():
    args = [DEMO_PLAN, "--scenarios", 3, "--parts", 5, "--fault", "dropout:0.5", "--json"]
    result = _invoke([*args, "--jobs", 1])
    data = json.loads(result.stdout)
    assert result.exit_code == (1 if data["violations"] else 0)
    (row,) = data["faults"]
    assert (row["fault"], row["what"]) == ("dropout:0.5", "readings dropped out")
    assert data["stopped"] == 0
    assert row["of"] == READINGS * 15  # 12 readings a part, 15 parts
    assert 0.35 * row["of"] < row["value"] < 0.65 * row["of"]  # 90 readings ± 6 (1σ)
    assert data["unavoidable_violations"] + data["avoidable_violations"] == data["violations"]
    assert data["avoidable_parts_made"] == 12  # parts 2..5 of 3 scenarios
    assert data["avoidable_probability_upper_95"] == clopper_pearson_upper(
        data["avoidable_violating_parts"], 12
    )
    again = _invoke([*args, "--jobs", 2])
    assert json.loads(again.stdout) == data


def test_cli_table_with_faults():
    args = [DEMO_PLAN, "--scenarios", 1, "--parts", 4, "--jobs", 1, "--fault", "step:3:1.2"]
    result = _invoke([*args, "--fault", "curvature", "--wear-drift", "0.1"])
    assert result.exit_code in (0, 1), result.stderr
    out = " ".join(result.stdout.split())  # the title wraps at the console's width
    assert "faults step:3:1.2 curvature:0.06 wear:0.1" in out
    assert "unavoidable" in out and "avoidable" in out
    assert "parts made with the step in force" in out and "2 of 4" in out


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--fault", "step:0:1.1"], ["--fault", "'step:0:1.1'", "PART"]),
        (["--fault", "nope"], ["--fault", "'nope'", "dropout"]),
        (["--fault", "wear", "--wear-drift", "0.1"], ["--wear-drift"]),
    ],
)
def test_cli_bad_fault(args, needles):
    result = _invoke([DEMO_PLAN, "--scenarios", 1, "--parts", 1, *args])
    assert result.exit_code == 2, (result.exit_code, result.stderr)
    assert result.stdout == "" and "Traceback" not in result.stderr
    line = result.stderr.strip()
    assert "\n" not in line and line.startswith("rcb: error: ")
    for needle in needles:
        assert needle in line, (needle, line)
