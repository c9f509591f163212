"""The virtual shop floor's fault catalogue: parsing, each fault's effect, the oracle, the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from typer.testing import CliRunner

from api.cli.main import app
from models.errors import InputError
from supervisor.inputs.plan import load_plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start
from supervisor.virtual.bound import clopper_pearson_upper
from supervisor.virtual.certificate import (
    Certificate,
    ScenarioTrace,
    digest,
    summarize,
)
from supervisor.virtual.certify import simulate
from supervisor.virtual.fault_oracle import truth_oracle
from supervisor.virtual.fault_spec import Fault, Faults, parse_fault, parse_faults
from supervisor.virtual.faults import (
    DROPOUT_FRACTION,
    PartFaults,
    draw_bends,
    fault_rng,
    part_faults,
    step_factor,
    unavoidable_parts,
)
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.scenario import run_scenario
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN

PLAN = load_plan(DEMO_PLAN)
MACHINE = sample_machine(PLAN, 3)
#: The robust optimum's setpoints: every operation inside its bounds.
SETPOINTS = {op.name: op.setpoint for op in optimize_plan(PLAN).operations}
#: Readings of a demo part: force and roughness of each of its six operations.
READINGS = 12


# --------------------------------------------------------------------------- parsing


@pytest.mark.parametrize(
    ("text", "kind", "arguments"),
    [
        ("dropout:0.1", "dropout", (0.1,)),
        ("noise-scale:2.5", "noise-scale", (2.5,)),
        ("step:20:0.9", "step", (20.0, 0.9)),
        ("curvature:0.1", "curvature", (0.1,)),
        ("wear:0.2", "wear", (0.2,)),
        (" dropout:1 ", "dropout", (1.0,)),
    ],
)
def test_parse_a_good_fault(text, kind, arguments):
    fault = parse_fault(text)
    assert fault == Fault(kind, arguments)
    assert parse_fault(fault.spec) == fault  # the spec reads back


@pytest.mark.parametrize(
    ("text", "spec"),
    [
        ("dropout", "dropout:0.03"),
        ("noise-scale", "noise-scale:3"),
        ("step", "step:15:1.12"),
        ("curvature", "curvature:0.06"),
        ("wear", "wear:0.05"),
    ],
)
def test_a_kind_alone_is_its_catalogue_default(text, spec):
    assert parse_fault(text).spec == spec


@pytest.mark.parametrize(
    "text",
    [
        "",
        "bogus",
        "dropout:",
        "dropout:1.5",
        "dropout:x",
        "dropout:0.1:2",
        "noise-scale:0",
        "step:0:1.1",
        "step:15",
        "step:1.5:1.1",
        "step:15:-1",
        "curvature:-0.1",
        "wear:nan",
        "wear:inf",
    ],
)
def test_parse_a_bad_fault_names_the_flag_and_the_value(text):
    with pytest.raises(InputError) as err:
        parse_fault(text)
    assert (err.value.field, err.value.value) == ("--fault", text)
    assert "--fault" in str(err.value)


def test_repeated_faults():
    faults = parse_faults(["step:20:0.9", "dropout", "step:5:1.1", "curvature:0.1"])
    assert faults.specs == ("step:20:0.9", "dropout:0.03", "step:5:1.1", "curvature:0.1")
    assert faults.steps == ((5, 1.1), (20, 0.9))  # by part
    assert (faults.dropout, faults.noise_scale, faults.curvature, faults.wear) == (
        0.03,
        1.0,
        0.1,
        0.0,
    )
    assert step_factor(faults, 4) == 1.0
    assert step_factor(faults, 5) == 1.1
    assert step_factor(faults, 20) == pytest.approx(1.1 * 0.9)
    with pytest.raises(InputError, match="dropout given twice"):
        parse_faults(["dropout", "dropout:0.1"])
    with pytest.raises(InputError, match="same part"):
        parse_faults(["step:5:1.1", "step:5:1.2"])
    assert not Faults() and parse_faults([]) == Faults()


def test_wear_drift_is_the_alias_of_the_wear_fault():
    assert parse_faults([], wear_drift=0.05) == parse_faults(["wear:0.05"])
    assert not parse_faults(["wear:0.05"]).beyond_wear
    with pytest.raises(InputError) as err:
        parse_faults(["wear:0.05"], wear_drift=0.1, wear_flag="--wear-drift")
    assert err.value.field == "--wear-drift"


# --------------------------------------------------------------------------- run_part


def _true_and_read(faults: PartFaults | None, seed: int = 1) -> tuple[dict, dict]:
    outcome = run_part(MACHINE, SETPOINTS, np.random.default_rng(seed), faults=faults)
    read = {op: {q: m.value for q, m in ms.items()} for op, ms in outcome.measurements.items()}
    return outcome.true_values, read


def test_no_fault_object_changes_nothing():
    plain = run_part(MACHINE, SETPOINTS, np.random.default_rng(1))
    neutral = run_part(MACHINE, SETPOINTS, np.random.default_rng(1), faults=PartFaults())
    assert plain == neutral


def test_a_dropped_reading_is_its_fraction_of_the_truth_and_the_others_are_untouched():
    # reading 0 is the rough-od force, reading 3 the rough-grooves roughness (plan order)
    faults = PartFaults(dropouts={0: 0.2, 3: 0.05})
    outcome = run_part(MACHINE, SETPOINTS, np.random.default_rng(1), faults=faults)
    true, read = outcome.true_values, outcome.measurements
    assert read["rough-od"]["force_N"].value == 0.2 * true["rough-od"]["force_N"]
    assert (
        read["rough-grooves"]["roughness_um"].value == 0.05 * true["rough-grooves"]["roughness_um"]
    )
    assert read["rough-od"]["force_N"].uncertainty == 3.0  # reported with the usual U
    assert outcome.dropped == (("rough-od", "force_N"), ("rough-grooves", "roughness_um"))
    plain = run_part(MACHINE, SETPOINTS, np.random.default_rng(1))
    assert read["rough-od"]["roughness_um"] == plain.measurements["rough-od"]["roughness_um"]
    assert true == plain.true_values


def test_dropout_rate_and_fractions_over_many_parts():
    p, parts = 0.2, 1500
    faults = parse_faults([f"dropout:{p}"])
    rng = fault_rng(7, "dropout")
    fractions = []
    for part in range(1, parts + 1):
        at = part_faults(faults, {}, part, rng, READINGS)
        outcome = run_part(MACHINE, SETPOINTS, np.random.default_rng(part), faults=at)
        for op, q in outcome.dropped:
            fractions.append(outcome.measurements[op][q].value / outcome.true_values[op][q])
    n = parts * READINGS
    # binomial: 0.2 of 18 000 readings is 3600 ± 54 (1σ); 4σ
    assert abs(len(fractions) - p * n) < 4 * math.sqrt(n * p * (1 - p))
    low, high = DROPOUT_FRACTION
    assert low <= min(fractions) and max(fractions) <= high
    assert min(fractions) < 0.06 and max(fractions) > 0.29  # the whole range is drawn
    assert_allclose(np.mean(fractions), 0.175, atol=0.005)  # U(0.05, 0.30): mean 0.175


def test_noise_scale_multiplies_the_noise_not_the_reported_u():
    true, plain = _true_and_read(None)
    _, scaled = _true_and_read(PartFaults(noise_scale=3.0))
    for op in true:
        for q in plain[op]:
            # the same standard normal, three times the sigma (no reading clipped at 0 here)
            assert_allclose(scaled[op][q] - true[op][q], 3 * (plain[op][q] - true[op][q]))
    # over many parts: sd of the rough-od force readings = S·U/2 = 3 · 3 N / 2 = 4.5 N
    rng = np.random.default_rng(11)
    errors = [
        run_part(MACHINE, SETPOINTS, rng, faults=PartFaults(noise_scale=3.0))
        .measurements["rough-od"]["force_N"]
        .value
        - true["rough-od"]["force_N"]
        for _ in range(3000)
    ]
    assert_allclose(np.std(errors, ddof=1), 4.5, rtol=0.05)  # sd of a sd: 1.3 % here


def test_a_step_multiplies_force_roughness_and_what_follows_force_from_its_part_on():
    faults = parse_faults(["step:3:1.5"])
    rng = fault_rng(0, "dropout")
    before, _ = _true_and_read(part_faults(faults, {}, 2, rng, READINGS))
    after, _ = _true_and_read(part_faults(faults, {}, 3, rng, READINGS))
    plain, _ = _true_and_read(None)
    assert before == plain
    for op in plain:
        for q in ("force_N", "roughness_um", "power_kW", "torque_Nm"):
            assert_allclose(after[op][q], 1.5 * plain[op][q], rtol=1e-12)
        assert after[op]["spindle_rpm"] == plain[op]["spindle_rpm"]
    assert after["rough-od"]["tool_life_mm3"] == plain["rough-od"]["tool_life_mm3"]
    assert unavoidable_parts(faults, 30) == (1, 3)
    assert unavoidable_parts(faults, 2) == (1,)  # a step after the last part is never made


def _box(op_name: str) -> tuple[np.ndarray, np.ndarray]:
    op = next(o for o in PLAN.operations if o.name == op_name)
    params = ("depth_mm", "feed_mm_rev", "speed_m_min")
    return np.log([op.bounds[p][0] for p in params]), np.log([op.bounds[p][1] for p in params])


def test_curvature_bends_ln_y_by_at_most_c_over_the_box_and_reaches_it():
    c = 0.06
    bends = draw_bends(MACHINE, 3, c)
    assert set(bends) == {op.name for op in PLAN.operations}
    assert draw_bends(MACHINE, 3, c) == bends  # deterministic
    assert draw_bends(MACHINE, 4, c) != bends
    grid = np.linspace(0.0, 1.0, 15)
    for name, per_model in bends.items():
        low, high = _box(name)
        assert set(per_model) == {
            q for q, _ in next(x for x in MACHINE.compiled if x.name == name).models
        }
        for bend in per_model.values():
            points = low + (high - low) * np.stack(
                np.meshgrid(grid, grid, grid, indexing="ij"), axis=-1
            ).reshape(-1, 3)
            on_grid = max(abs(bend.at(p.tolist())) for p in points)
            assert on_grid <= c * (1 + 1e-12)
            # the exact maximum: a corner z = ±sign(w) (t = ±1) or the ridge's vertex t*
            mid, sign = (low + high) / 2, np.sign(bend.slope)
            corners = [abs(bend.at((mid + s * sign * (high - low) / 2).tolist())) for s in (1, -1)]
            vertex = -bend.linear / (2 * bend.quadratic)
            top = max(corners)
            if abs(vertex) <= 1:
                top = max(top, abs(bend.amplitude * bend.linear * vertex / 2))
            assert_allclose(top, c, rtol=1e-12)
            assert on_grid > 0.9 * c  # a 15-point grid comes close


def test_curvature_in_run_part_is_exp_of_the_bend():
    bends = draw_bends(MACHINE, 3, 0.06)
    plain, _ = _true_and_read(None)
    bent, _ = _true_and_read(PartFaults(bends=bends))
    for op in PLAN.operations:
        ln_x = [math.log(SETPOINTS[op.name][p]) for p in ("depth_mm", "feed_mm_rev", "speed_m_min")]
        for q, bend in bends[op.name].items():
            assert_allclose(bent[op.name][q] / plain[op.name][q], math.exp(bend.at(ln_x)))
        # power follows the bent force
        ratio = bent[op.name]["power_kW"] / plain[op.name]["power_kW"]
        assert_allclose(ratio, math.exp(bends[op.name]["force_N"].at(ln_x)))


def test_wear_fault_equals_wear_drift():
    initial = start(PLAN, RcbSettings(strategy="ivester"))
    a = run_scenario(initial, 4, 12, wear_drift_per_edge_life=0.05)
    b = run_scenario(initial, 4, 12, faults=parse_faults(["wear:0.05"]))
    for name in ("plan_ratio", "op_ratio", "cycle_min", "violations"):
        assert_array_equal(getattr(a, name), getattr(b, name))
    assert (a.where, a.oracle_cycle_min) == (b.where, b.oracle_cycle_min)
    assert b.tallies[0].fault == "wear:0.05" and 0 < b.tallies[0].value < 0.05


# --------------------------------------------------------------------------- the closed loop


def test_fault_free_results_are_those_from_before_the_catalogue():
    # digests of the same calls on commit 820403c, the code before the fault catalogue, were
    # aabf515a2a9d and d17dc7599040 (checked when the catalogue landed); issue 27's rules
    # changed what the learner does (1725bcc25ab8 / d17dc7599040, then 4b5d8fd417bc /
    # d17dc7599040 with learn's noise scale per measuring chain at its upper quantile and no
    # noise learned from a drift in progress), and
    # these are today's: without a fault, the catalogue changes nothing, and wear:0.05 is
    # --wear-drift 0.05
    assert digest(simulate(PLAN, ["ivester", "learn"], scenarios=3, parts=12)) == "4b5d8fd417bc"
    wear = simulate(PLAN, ["ivester"], scenarios=2, parts=12, seed=4, wear_drift_per_edge_life=0.05)
    assert digest(wear) == "d17dc7599040"
    worn = simulate(
        PLAN, ["ivester"], scenarios=2, parts=12, seed=4, faults=parse_faults(["wear:0.05"])
    )
    assert digest(worn) == "d17dc7599040"


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
