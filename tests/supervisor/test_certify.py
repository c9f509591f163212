"""The Monte Carlo certificate: Clopper-Pearson bound, the closed-loop engine, ``rcb certify``."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from typer.testing import CliRunner

from api.cli.main import app
from models.errors import InputError
from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import load_plan
from supervisor.rcb.state import Halt, HaltedOperation, RcbSettings
from supervisor.rcb.strategies import DEFAULT_STRATEGY
from supervisor.rcb.update import start
from supervisor.virtual import certify, scenario
from supervisor.virtual.bound import clopper_pearson_upper
from supervisor.virtual.certificate import (
    Certificate,
    digest,
    summarize,
    summary_rows,
)
from supervisor.virtual.certify import simulate
from supervisor.virtual.scenario import run_scenario

ROOT = Path(__file__).resolve().parents[2]
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"
PLAN = load_plan(DEMO_PLAN)

JSON_KEYS = {
    "plan",
    "strategy",
    "scenarios",
    "parts",
    "seed",
    "violations",
    "stopped",
    "violation_probability_upper_95",
    "unavoidable_violations",
    "avoidable_violations",
    "avoidable_violating_parts",
    "avoidable_parts_made",
    "avoidable_probability_upper_95",
    "faults",
    "mrr_over_oracle",
}


# --------------------------------------------------------------------------- Clopper-Pearson


def test_clopper_pearson_no_failures_is_the_rule_of_three_exactly():
    # 0 of n: (1 - p)^n = 0.05, p = 1 - 0.05^(1/n); 6000 parts = 200 scenarios x 30 parts
    assert_allclose(clopper_pearson_upper(0, 6000), 1 - 0.05 ** (1 / 6000), rtol=1e-12)
    assert_allclose(clopper_pearson_upper(0, 6000), 4.9916e-4, rtol=1e-4)  # about 3/n
    assert_allclose(clopper_pearson_upper(0, 10), 0.25887, rtol=1e-4)


def test_clopper_pearson_three_of_a_thousand():
    # beta.ppf(0.95, 4, 997); the same by the F form, (x+1)F / (n-x + (x+1)F) with
    # F = F_0.95(8, 1994), and close to the Poisson table's one-sided 95 % upper limit for
    # 3 events, 7.75 (chi2_0.95(8)/2 = 7.754), over n = 1000 (the binomial is a little lower)
    upper = clopper_pearson_upper(3, 1000)
    assert_allclose(upper, 0.0077352, rtol=1e-4)
    assert 0.0077 < upper < 7.754e-3


def test_clopper_pearson_edges():
    assert clopper_pearson_upper(5, 5) == 1.0
    assert clopper_pearson_upper(0, 0) == 1.0
    assert clopper_pearson_upper(1, 100) > clopper_pearson_upper(0, 100)
    with pytest.raises(InputError, match="failures"):
        clopper_pearson_upper(6, 5)
    with pytest.raises(InputError, match="confidence"):
        clopper_pearson_upper(0, 5, confidence=1.0)


def test_summary_rows():
    assert summary_rows(30) == (1, 5, 10, 30)
    assert summary_rows(10) == (1, 5, 10)
    assert summary_rows(3) == (1, 3)
    assert summary_rows(1) == (1,)


# --------------------------------------------------------------------------- the engine


def _same(a: Certificate, b: Certificate) -> None:
    assert len(a.scenarios) == len(b.scenarios)
    for x, y in zip(a.scenarios, b.scenarios, strict=True):
        assert x.seed == y.seed
        assert x.oracle_cycle_min == y.oracle_cycle_min
        for name in ("plan_ratio", "op_ratio", "cycle_min", "violations"):
            assert_array_equal(getattr(x, name), getattr(y, name), err_msg=name)
        assert (x.where, x.stopped_at, x.stopped_op, x.parts_made) == (
            y.where,
            y.stopped_at,
            y.stopped_op,
            y.parts_made,
        )


def test_engine_is_deterministic_and_the_same_for_any_jobs():
    runs = [
        simulate(PLAN, ["ivester", "bayes"], scenarios=3, parts=3, seed=5, jobs=jobs)
        for jobs in (1, 1, 2)
    ]
    for run in runs[1:]:
        for a, b in zip(runs[0], run, strict=True):
            _same(a, b)
    assert len({digest(run) for run in runs}) == 1
    ivester = runs[0][0]
    assert [s.seed for s in ivester.scenarios] == [5, 6, 7]
    assert ivester.plan_ratio.shape == (3, 4)
    assert ivester.op_ratio.shape == (3, 4, len(PLAN.operations))
    assert ivester.parts_made == 9
    # a scenario depends only on its seed: seed 6 alone is the second scenario above
    alone = simulate(PLAN, ["ivester"], scenarios=1, parts=3, seed=6)[0]
    _same(alone, Certificate(**{**vars(ivester), "scenarios": ivester.scenarios[1:2]}))


def test_summary_of_a_small_certificate():
    certificate = simulate(PLAN, ["ivester"], scenarios=3, parts=3)[0]
    summary = summarize(certificate)
    assert [r.after_parts for r in summary.rows] == [1, 3]
    assert summary.violations == 0 and summary.stopped == 0
    assert summary.total.parts_made == 9
    assert_allclose(summary.violation_probability_upper_95, 1 - 0.05 ** (1 / 9), rtol=1e-12)
    ratio = certificate.plan_ratio
    for row in summary.rows:
        k = row.after_parts
        assert row.mrr_over_oracle_mean == pytest.approx(ratio[:, k].mean())
        assert row.mrr_over_oracle_p5 == pytest.approx(np.percentile(ratio[:, k], 5.0))
        assert 0.5 < row.mrr_over_oracle_p5 <= row.mrr_over_oracle_mean <= 1.0 + 1e-9


def test_a_scenario_stops_when_update_halts(monkeypatch):
    """rcb.update halts a plan whose bands leave no safe setpoint: the scenario stops there."""
    real_update = scenario.update
    calls = 0

    def update(state, report):
        nonlocal calls
        calls += 1
        new, decisions = real_update(state, report)
        if calls < 2:
            return new, decisions
        halted = HaltedOperation("finish-od", (), (), "no safe setpoint")
        return replace(new, halt=Halt((halted,))), decisions

    monkeypatch.setattr(scenario, "update", update)
    initial = start(PLAN, RcbSettings(strategy="ivester"))
    trace = run_scenario(initial, 3, 5)
    assert trace.stopped and trace.stopped_at == 2 and trace.parts_made == 2
    assert trace.stopped_op == "finish-od"
    assert np.all(trace.plan_ratio[:2] > 0) and np.all(trace.plan_ratio[2:] == 0)
    assert np.all(np.isnan(trace.cycle_min[2:]))
    assert trace.violations.shape == (5,)


def test_wear_drift_changes_the_edges_and_is_deterministic():
    one = simulate(PLAN, ["ivester"], scenarios=2, parts=12, wear_drift_per_edge_life=0.5)
    two = simulate(PLAN, ["ivester"], scenarios=2, parts=12, wear_drift_per_edge_life=0.5)
    assert digest(one) == digest(two)
    plain = simulate(PLAN, ["ivester"], scenarios=2, parts=12)
    assert digest(one) != digest(plain)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"scenarios": 0}, "scenarios"),
        ({"scenarios": certify.MAX_SCENARIOS + 1}, "scenarios"),
        ({"parts": 0}, "parts"),
        ({"parts": certify.MAX_PARTS + 1}, "parts"),
        ({"jobs": 0}, "jobs"),
        ({"seed": -1}, "seed"),
        ({"wear_drift_per_edge_life": math.nan}, "wear_drift_per_edge_life"),
    ],
)
def test_engine_refuses_bad_counts(kwargs, field):
    args = {"scenarios": 2, "parts": 2, **kwargs}
    with pytest.raises(InputError) as err:
        simulate(PLAN, ["ivester"], **args)
    assert err.value.field == field


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_domain_error_in_a_scenario_reaches_the_caller_as_itself(monkeypatch, jobs):
    """InputError and InfeasibleError do not pickle back from a worker; the parent re-runs."""
    real = scenario.sample_machine

    def sample_machine(plan, seed, **kwargs):
        if seed == 2:
            raise InfeasibleError("rough-od", (), ())
        return real(plan, seed, **kwargs)

    monkeypatch.setattr(scenario, "sample_machine", sample_machine)  # forked workers see it
    with pytest.raises(InfeasibleError, match="rough-od"):
        simulate(PLAN, ["ivester"], scenarios=4, parts=1, jobs=jobs)


def test_engine_refuses_an_unknown_strategy():
    with pytest.raises(InputError, match="strategy"):
        simulate(PLAN, ["nope"], scenarios=1, parts=1)


# --------------------------------------------------------------------------- rcb certify


def _invoke(args):
    result = CliRunner().invoke(app, ["certify", *map(str, args)])
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(
        result.exception
    )
    return result


def test_cli_json():
    result = _invoke([DEMO_PLAN, "--scenarios", 4, "--parts", 3, "--json"])
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert set(data) == JSON_KEYS
    assert data["plan"] == "ivester-demo-part"
    assert (data["strategy"], data["scenarios"], data["parts"], data["seed"]) == (
        DEFAULT_STRATEGY,
        4,
        3,
        0,
    )
    assert data["violations"] == 0 and data["stopped"] == 0
    assert_allclose(data["violation_probability_upper_95"], 1 - 0.05 ** (1 / 12), rtol=1e-12)
    # part 1 of each scenario is unavoidable: 4 scenarios x parts 2..3 are avoidable
    assert (data["unavoidable_violations"], data["avoidable_violations"]) == (0, 0)
    assert data["avoidable_parts_made"] == 8 and data["faults"] == []
    assert_allclose(data["avoidable_probability_upper_95"], 1 - 0.05 ** (1 / 8), rtol=1e-12)
    assert list(data["mrr_over_oracle"]) == ["1", "3"]
    for row in data["mrr_over_oracle"].values():
        assert set(row) == {"mean", "p5"}
        assert 0 < row["p5"] <= row["mean"] <= 1 + 1e-9
    # the same scenarios in one process give the same numbers
    again = _invoke([DEMO_PLAN, "--scenarios", 4, "--parts", 3, "--json", "--jobs", 1])
    assert json.loads(again.stdout) == data


def test_cli_table_and_exit_code_1_on_violations():
    result = _invoke([DEMO_PLAN, "--scenarios", 2, "--parts", 3, "--jobs", 1])
    assert result.exit_code == 0, result.stderr
    assert "after k" in result.stdout and "Clopper-Pearson" in result.stdout
    assert max(map(len, result.stdout.splitlines())) <= 80
    # a process 30 % harder from part 2 on crosses at part 2 on any strategy (unavoidable):
    # the JSON is still printed, then exit 1
    crossing = [DEMO_PLAN, "--strategy", "bayes", "--fault", "step:2:1.3", "--scenarios", 1]
    result = _invoke([*crossing, "--parts", 3, "--jobs", 1, "--json"])
    assert result.exit_code == 1, result.stderr
    certificate = json.loads(result.stdout)
    assert certificate["violations"] == certificate["unavoidable_violations"] == 7


def test_bayes_reads_a_low_reading_at_the_chains_bound_and_does_not_cross():
    """Seed 902: before 2026-12-06 bayes crossed rough-grooves' roughness at part 12.

    Part 11's reading was 4.9 σ low (1.816 µm for a true 1.939), the conjugate update of
    ln K at the reported u followed it and the next setpoint went past the limit; read at the
    chain's bound scale (Q u) the update moves less (docs/benchmarks.md).
    """
    clean = [DEMO_PLAN, "--strategy", "bayes", "--seed", 902, "--scenarios", 1]
    result = _invoke([*clean, "--parts", 12, "--jobs", 1, "--json"])
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)["violations"] == 0


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--strategy", "bogus"], ["--strategy", "'bogus'", "ivester"]),
        # the value as given, a number bare (api.cli.usage_words), and what it must be
        (["--scenarios", "0"], ["--scenarios = 0: must be at least 1"]),
        (["--scenarios", "100001"], ["--scenarios = 100001: must be at most 100000"]),
        (["--parts", "0"], ["--parts = 0: must be at least 1"]),
        (["--parts", "1001"], ["--parts = 1001: must be at most"]),
        (["--wear-drift", "-1"], ["--wear-drift", "-1"]),
        (["--jobs", "0"], ["--jobs = 0: must be at least 1"]),
    ],
)
def test_cli_bad_options(args, needles):
    result = _invoke([DEMO_PLAN, *args, "--json"])
    _one_line_error(result, needles)


def test_cli_missing_plan_file(tmp_path):
    missing = tmp_path / "no-such-plan.toml"
    _one_line_error(_invoke([missing]), ["plan file", str(missing), "no such file"])


def _one_line_error(result, needles):
    assert result.exit_code == 2, (result.exit_code, result.stderr)
    assert result.stdout == ""
    line = result.stderr.removesuffix("\n")
    assert "\n" not in line and "Traceback" not in line, result.stderr
    assert line.startswith("rcb: error: ")
    for needle in needles:
        assert needle in line, (needle, line)
