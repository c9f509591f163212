"""Borangiu's (w, n) domain (Eqs. 2-7): max MRR as an LP, least J as a GP, Eqs. 10-12.

The pass of ``examples/borangiu_domain.toml``: Ø10 mm, 4 flutes, 2 x 5 mm in steel
(7.85 t/m³); deflection K_d = 0.32 mm/rev is the tightest mechanical load (K_t 0.48,
K_fM 0.6); 20-3000 mm/min, 500-6000 rpm; P = 3.1e-4·w^0.75·n^0.25 kW <= 2.2 kW; Taylor
v·T^0.25·fz^0.5 = 132; tool 40, wage 1.0/min, energy 0.15/kWh, 0.3 kW for 3 min per change,
5 min regrinding.
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from pathlib import Path
from typing import Any

import pytest
import typer
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from api.cli.domain import domain as domain_command
from models import borangiu_cost
from models.errors import InputError
from supervisor.borangiu.problem import domain_problem_from_mapping, load_domain_problem
from supervisor.errors import InfeasibleError
from supervisor.optimize import productivity
from supervisor.optimize.formulation import formulate_domain
from supervisor.optimize.optimizer import optimize_domain

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "borangiu_domain.toml"
with EXAMPLE.open("rb") as _f:
    _DATA: dict[str, Any] = tomllib.load(_f)

# J's coefficients by hand (models/borangiu_cost.py module doc), per kg of steel
# removed:
# mass per mm of feed = 1e-6 kg/(mm³·t/m³) · 7.85 t/m³ · 2 mm · 5 mm = 7.85e-5 kg/mm.
MASS = 1e-6 * 7.85 * 2 * 5
PER_LIFE = 40 + 0.15 * 0.3 * 3 / 60 + 1.0 * 5  # tool + change energy + regrinding = 45.00225
A = PER_LIFE / MASS * (math.pi * 10 / (1000 * 4**0.5 * 132)) ** (1 / 0.25)  # 1.1496e-10
B = 0.15 * 3.1e-4 / 60 / MASS  # 0.0098726
C = 1.0 / MASS  # 12738.85
Q, M, YP = 0.5, 0.25, 0.75
K_D = 0.32


def data() -> dict[str, Any]:
    return copy.deepcopy(_DATA)


def J(w: float, n: float) -> float:
    return A * w ** (Q / M - 1) * n ** ((1 - Q) / M) + B * w ** (YP - 1) * n ** (1 - YP) + C / w


def solve(d: dict[str, Any]):
    return optimize_domain(domain_problem_from_mapping(d))


def test_coefficients_from_the_cost_data():
    problem = load_domain_problem(EXAMPLE)
    c = problem.coefficients
    assert_allclose([c.a, c.b, c.c], [A, B, C], rtol=1e-12)
    assert_allclose([c.a, c.b, c.c], [1.1496e-10, 0.0098726, 12738.85], rtol=1e-4)
    assert (c.q, c.m, c.yp) == (Q, M, YP)
    assert_allclose(problem.domain.power_bound, 2.2 / 3.1e-4)  # K_p of Eq. 7


def test_the_geometric_program_is_dgp_and_dpp():
    problem = formulate_domain(load_domain_problem(EXAMPLE))
    gp = productivity.dgp_problem(problem)
    assert gp.is_dgp(dpp=True)
    assert gp.is_dpp("dgp")
    assert not gp.is_dcp()  # a posynomial objective is not convex in (w, n) itself


def test_single_mechanical_load_optimum_is_borangiu_eq10():
    # On the line w = K_d·n only deflection (Eq. 3) is active. There n = w/K_d and
    #   J = a·K_d^(-(1-q)/m)·w^(1/m-1) + b·K_d^(yp-1) + c/w,
    # whose derivative vanishes at w0 = K_d^(1-q)·(m·c/((1-m)·a))^m, n0 = w0/K_d
    # (Eq. 10 with C_1 = 1/K_d): 1394.57 mm/min, 4358.03 rpm.
    scale = (M * C / ((1 - M) * A)) ** M
    w0, n0 = K_D ** (1 - Q) * scale, K_D ** (1 - Q) * scale / K_D
    assert_allclose([w0, n0], [1394.57, 4358.03], rtol=1e-5)
    result = optimize_domain(load_domain_problem(EXAMPLE))
    best = result.min_cost
    assert_allclose([best.feed_rate_mm_min, best.spindle_rpm], [w0, n0], rtol=1e-4)
    assert best.active == ("domain.max_deflection_feed_mm_rev",)
    assert result.mechanical_limit == "domain.max_deflection_feed_mm_rev"
    assert_allclose(result.stationary, (w0, n0), rtol=1e-12)
    # ... on the curve (12) w^q·n^(1-q) = (m·c/((1-m)·a))^m
    assert_allclose(best.feed_rate_mm_min**Q * best.spindle_rpm ** (1 - Q), scale, rtol=1e-4)
    # ... where the tool lasts the least-cost life (1/m - 1)·45.00225/1.0 = 135.0 min (Shaw ch. 19)
    assert_allclose(best.tool_life_min, 3 * PER_LIFE, rtol=1e-4)
    assert_allclose(best.cost_per_kg, J(w0, n0), rtol=1e-8)
    assert_allclose(best.cost_per_kg, 12.1926, rtol=1e-4)


def test_max_mrr_sits_at_the_corner_the_lp_predicts():
    # max w on w <= K_d·n <= 0.32·6000 = 1920 mm/min < w_max 3000: deflection meets n_max
    result = optimize_domain(load_domain_problem(EXAMPLE))
    fast = result.max_feed_rate
    assert_allclose([fast.feed_rate_mm_min, fast.spindle_rpm], [1920, 6000], rtol=1e-7)
    assert set(fast.active) == {"domain.max_deflection_feed_mm_rev", "domain.max_spindle_rpm"}
    assert_allclose(fast.mrr_cm3_min, 1920 * 2 * 5 / 1000, rtol=1e-7)  # 19.2 cm³/min
    # J there: 14.594 /kg, 19.70 % above the optimum 12.1926; the optimum feeds 27.37 % slower
    assert_allclose(fast.cost_per_kg, J(1920, 6000), rtol=1e-7)
    assert_allclose(fast.cost_per_kg, 14.5940, rtol=1e-4)
    assert result.min_cost.cost_per_kg < fast.cost_per_kg
    assert_allclose(result.cost_increase_percent, 100 * (J(1920, 6000) / 12.192611 - 1), rtol=1e-5)
    assert_allclose(result.cost_increase_percent, 19.696, rtol=1e-4)
    assert_allclose(result.feed_rate_decrease_percent, 100 * (1 - 1394.5695 / 1920), rtol=1e-4)


def test_power_active_instead_moves_the_optimum_to_the_power_curve():
    # 0.45 kW < 0.575 kW drawn at Eq. 10's point: the optimum is where the line w = K_d·n
    # meets w^yp·n^(1-yp) = K_p = 0.45/3.1e-4: w = K_p·K_d^(1-yp), n = K_p·K_d^(-yp)
    # (1091.79 mm/min, 3411.84 rpm), Borangiu Fig. 7's "electric power" intersection.
    d = data()
    d["domain"]["max_power_kW"] = 0.45
    result = solve(d)
    kp = 0.45 / 3.1e-4
    w, n = kp * K_D ** (1 - YP), kp * K_D ** (-YP)
    assert_allclose([w, n], [1091.79, 3411.84], rtol=1e-5)
    best = result.min_cost
    assert_allclose([best.feed_rate_mm_min, best.spindle_rpm], [w, n], rtol=1e-4)
    assert set(best.active) == {"domain.max_deflection_feed_mm_rev", "domain.max_power_kW"}
    assert_allclose(best.power_kW, 0.45, rtol=1e-6)
    assert best.cost_per_kg > 12.1926  # dearer than the unconstrained Eq. 10 point
    # the fastest point is the same corner: w = K_p·(w/n)^(1-yp) grows with w/n
    assert_allclose(result.max_feed_rate.feed_rate_mm_min, w, rtol=1e-6)


def test_ties_of_the_fastest_feed_rate_take_the_cheapest_point():
    # w_max = 1500 binds before deflection: every n in [1500/0.32, 6000] feeds 1500 mm/min;
    # J rises with n at fixed w (positive exponents), so the least-J tie is n = 4687.5 rpm.
    d = data()
    d["domain"]["max_feed_rate_mm_min"] = 1500
    fast = solve(d).max_feed_rate
    assert_allclose([fast.feed_rate_mm_min, fast.spindle_rpm], [1500, 1500 / K_D], rtol=1e-6)
    assert set(fast.active) == {"domain.max_feed_rate_mm_min", "domain.max_deflection_feed_mm_rev"}


def test_the_coefficient_form_gives_the_same_optima():
    d = data()
    d["productivity"] = {"a": A, "b": B, "c": C, "q": Q, "m": M}  # yp: the domain's 0.75
    by_coefficients = solve(d)
    by_cost = optimize_domain(load_domain_problem(EXAMPLE))
    assert_allclose(by_coefficients.min_cost.feed_rate_mm_min, 1394.5695, rtol=1e-4)
    assert by_coefficients.min_cost.tool_life_min is None  # no Taylor constants given
    assert_allclose(by_coefficients.min_cost.cost_per_kg, by_cost.min_cost.cost_per_kg, rtol=1e-9)


@pytest.mark.parametrize(
    ("change", "named"),
    [
        # K_fm 0.5 above K_d 0.32 and K_t 0.48
        ({"min_pitch_feed_mm_rev": 0.5}, ["domain.min_pitch_feed_mm_rev", "max_deflection"]),
        # 0.01 kW cannot turn even 20 mm/min at 500 rpm: 3.1e-4·20^0.75·500^0.25 = 0.0139 kW
        ({"max_power_kW": 0.01}, ["domain.max_power_kW <= 0.01", "0.01386"]),
        # w_min 2500 needs n >= 2500/0.32 = 7812.5 rpm > n_max 6000
        ({"min_feed_rate_mm_min": 2500}, ["max_deflection_feed_mm_rev", "6000"]),
    ],
)
def test_infeasible_domains_name_the_conflicting_constraints(change, named):
    d = data()
    d["domain"].update(change)
    with pytest.raises(InfeasibleError) as err:
        solve(d)
    for text in named:
        assert text in str(err.value)


def test_min_cost_is_never_above_any_feasible_point_on_a_grid():
    result = optimize_domain(load_domain_problem(EXAMPLE))
    least = result.min_cost.cost_per_kg
    for w in (20, 100, 500, 1000, 1394.57, 2000, 3000):
        for n in (500, 1000, 2000, 4358.03, 5000, 6000):
            if 0.04 <= w / n <= 0.32 and 3.1e-4 * w**0.75 * n**0.25 <= 2.2:
                assert least <= J(w, n) * (1 + 1e-9), (w, n)


@settings(max_examples=40, deadline=None)
@given(
    k_d=st.floats(0.1, 0.6),
    tool_cost=st.floats(5, 200),
    wage=st.floats(0.2, 3),
    w=st.floats(20, 3000),
    n=st.floats(500, 6000),
)
def test_eq10_whenever_it_lies_inside_and_never_above_a_feasible_point(k_d, tool_cost, wage, w, n):
    d = data()
    d["domain"]["max_deflection_feed_mm_rev"] = k_d
    d["productivity"].update(tool_cost=tool_cost, wage_rate_per_min=wage)
    problem = domain_problem_from_mapping(d)
    result = optimize_domain(problem)
    best = result.min_cost
    terms = borangiu_cost.wn_terms(problem.coefficients)
    dom = problem.domain
    feasible = 0.04 <= w / n <= min(k_d, 0.48, 0.6) and dom.power_kW(w, n) <= 2.2
    if feasible:
        point = {"feed_rate_mm_min": w, "spindle_rpm": n}
        assert best.cost_per_kg <= borangiu_cost.evaluate(terms, point) * (1 + 1e-7)
    w0, n0 = result.stationary
    limit = min(k_d, 0.48)
    inside = 20 < w0 < 3000 and 500 < n0 < 6000 and dom.power_kW(w0, n0) < 2.2
    if inside:
        assert_allclose([best.feed_rate_mm_min, best.spindle_rpm], [w0, n0], rtol=1e-4)
        assert_allclose(best.pitch_feed_mm_rev, limit, rtol=1e-6)


# --- the domain file ----------------------------------------------------------------------------


def _without(d: dict[str, Any], table: str, key: str) -> dict[str, Any]:
    del d[table][key]
    return d


@pytest.mark.parametrize(
    ("mutate", "field", "fragment"),
    [
        (lambda d: _without(d, "domain", "max_spindle_rpm"), "domain.max_spindle_rpm", "required"),
        (
            lambda d: _without(d, "domain", "power_coefficient_kW"),
            "domain.power_coefficient_kW",
            "Eq. 7 needs",
        ),
        (lambda d: d["domain"].update(max_torque_Nm=40), "domain.max_torque_Nm", "unknown field"),
        (
            lambda d: d["domain"].update(min_spindle_rpm=7000),
            "domain.min_spindle_rpm",
            "above domain.max_spindle_rpm",
        ),
        (lambda d: d["domain"].update(power_exponent=1.2), "domain.power_exponent", "(0, 1)"),
        (
            lambda d: d["domain"].update(max_deflection_feed_mm_rev=-1),
            "domain.max_deflection_feed_mm_rev",
            "greater than 0",
        ),
        (lambda d: d.pop("cut"), "cut", "required with the cost data"),
        (lambda d: d["cut"].update(flute_count=3.5), "cut.flute_count", "whole number"),
        (lambda d: d["productivity"].update(taylor_m=1.5), "productivity.taylor_m", "(0, 1)"),
        (lambda d: d["productivity"].update(taylor_q=1.0), "productivity.taylor_q", "[0, 1)"),
        (lambda d: d["productivity"].update(a=1e-10), "productivity.tool_cost", "not both"),
        (
            lambda d: _without(d, "productivity", "density_t_m3"),
            "productivity.density_t_m3",
            "required",
        ),
        (lambda d: d["productivity"].update(tool_cost="40"), "productivity.tool_cost", "number"),
        (
            lambda d: d.update(
                productivity={"a": 1, "b": 0, "c": 1, "q": 0.5, "m": 0.25, "yp": 0.7}
            ),
            "productivity.yp",
            "differs from the domain's power_exponent 0.75",
        ),
        (
            lambda d: d.update(productivity={"a": 1, "b": 0, "q": 0.5, "m": 0.25}),
            "productivity.c",
            "required",
        ),
        (lambda d: d.pop("domain"), "domain", "required table missing"),
    ],
)
def test_domain_file_errors_name_the_field(mutate, field, fragment):
    d = data()
    mutate(d)
    with pytest.raises(InputError) as err:
        domain_problem_from_mapping(d)
    assert err.value.field == field
    assert fragment in str(err.value)


# --- rcb milling domain -------------------------------------------------------------------------

_app = typer.Typer()
_app.command()(domain_command)


def _write(tmp_path: Path, d: dict[str, Any]) -> Path:
    lines = [f"name = {json.dumps(d['name'])}"]
    for table in ("cut", "domain", "productivity"):
        if table in d:
            lines.append(f"[{table}]")
            lines += [f"{k} = {json.dumps(v)}" for k, v in d[table].items()]
    path = tmp_path / "pass.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_cli_json_gives_both_optima_and_the_comparison():
    result = CliRunner().invoke(_app, [str(EXAMPLE), "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.stdout)
    assert_allclose(out["max_mrr"]["feed_rate_mm_min"], 1920, rtol=1e-7)
    assert_allclose(out["max_mrr"]["mrr_cm3_min"], 19.2, rtol=1e-7)
    assert_allclose(out["min_cost"]["feed_rate_mm_min"], 1394.5695, rtol=1e-4)
    assert_allclose(out["min_cost"]["cost_per_kg"], 12.1926, rtol=1e-4)
    assert_allclose(out["cost_increase_percent"], 19.696, rtol=1e-4)
    assert out["min_cost"]["active"] == ["domain.max_deflection_feed_mm_rev"]
    assert_allclose(out["stationary_point_eq10"]["spindle_rpm"], 4358.03, rtol=1e-5)
    assert_allclose(out["coefficients"]["c"], C)


def test_cli_table_prints_the_percentage():
    result = CliRunner().invoke(_app, [str(EXAMPLE)], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    assert "J at the max-MRR point is 19.7 % above the J optimum" in result.stdout
    assert "max_deflection_feed_mm_rev (Eq. 3)" in result.stdout
    assert "1920" in result.stdout and "1395" in result.stdout


def test_cli_bad_input_is_one_line_exit_2(tmp_path):
    d = data()
    d["domain"]["min_spindle_rpm"] = -5
    result = CliRunner().invoke(_app, [str(_write(tmp_path, d))])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [
        "rcb: error: domain.min_spindle_rpm = -5: must be greater than 0"
    ]


def test_cli_infeasible_is_exit_3_naming_the_constraints(tmp_path):
    d = data()
    d["domain"]["min_pitch_feed_mm_rev"] = 0.5
    result = CliRunner().invoke(_app, [str(_write(tmp_path, d))])
    assert result.exit_code == 3
    (line,) = result.stderr.strip().splitlines()
    assert "domain.min_pitch_feed_mm_rev" in line and "Traceback" not in result.output
