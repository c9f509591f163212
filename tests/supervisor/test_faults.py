"""The virtual shop floor's fault catalogue: parsing, and each fault's effect on a part."""

from __future__ import annotations

import math

import numpy as np
import pytest
from faults_support import PLAN, READINGS
from numpy.testing import assert_allclose, assert_array_equal

from models.errors import InputError
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start
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

MACHINE = sample_machine(PLAN, 3)
#: The robust optimum's setpoints: every operation inside its bounds.
SETPOINTS = {op.name: op.setpoint for op in optimize_plan(PLAN).operations}


# --------------------------------------------------------------------------- parsing


@pytest.mark.parametrize(
    ("text", "kind", "arguments"),
    [
        ("dropout:0.1", "dropout", (0.1,)),
        ("noise-scale:2.5", "noise-scale", (2.5,)),
        ("step:20:0.9", "step", (20.0, 0.9)),
        ("curvature:0.1", "curvature", (0.1,)),
        ("wear:0.2", "wear", (0.2,)),
        ("noise-step:300:2.5", "noise-step", (300.0, 2.5)),
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
        ("noise-step", "noise-step:500:3"),
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
        "noise-step:500",
        "noise-step:0:3",
        "noise-step:500:0",
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


def test_a_noise_step_multiplies_the_noise_from_its_part_on_with_noise_scale():
    faults = parse_faults(["noise-scale:2", "noise-step:500:3"])
    assert faults.noise_step == (500, 3.0)
    rng = np.random.default_rng(0)
    assert part_faults(faults, {}, 499, rng, READINGS).noise_scale == 2.0
    assert part_faults(faults, {}, 500, rng, READINGS).noise_scale == 6.0
    assert parse_faults(["noise-step:7:3"]).noise_scale_at(6) == 1.0
    assert parse_faults([]).noise_step is None
    with pytest.raises(InputError, match="noise-step given twice"):
        parse_faults(["noise-step", "noise-step:9:2"])


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
