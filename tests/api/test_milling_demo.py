"""`rcb demo --milling`: a slot and a side finish on a virtual mill, force from spindle current."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from api.cli.main import app
from api.services.read.plan_parts import parts
from db.engine import make_engine
from models.sensors import to_force
from models.sensors.kim_jeon import LinearCurrentCalibration
from models.sensors.kim_jeon_feed import KIM_JEON_SPINDLE_FMAX_4500RPM
from supervisor.inputs.plan import load_plan
from supervisor.virtual.sensing import reading_for_force

ROOT = Path(__file__).resolve().parents[2]
PLAN = ROOT / "examples" / "milling_demo_part.toml"


def _derive():
    spec = importlib.util.spec_from_file_location(
        "derive", ROOT / "examples/derive_milling_models.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def milling_json(tmp_path_factory):
    db = f"sqlite:///{tmp_path_factory.mktemp('demo') / 'demo.db'}"
    args = ["demo", "--milling", "--json", "--plan", str(PLAN), "--db", db]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def _op(data, name):
    return next(op for op in data["operations"] if op["name"] == name)


def test_the_stored_parts_hold_the_spindle_current_as_read(tmp_path):
    """The demo's MES reports the slot's force as the spindle current it read, and the service
    converts it (as a plant's would): the stored part keeps the reading beside the force."""
    db = f"sqlite:///{tmp_path / 'demo.db'}"
    done = CliRunner().invoke(app, ["demo", "--milling", "--parts", "2", "--db", db, "--json"])
    assert done.exit_code == 0, done.output
    engine = make_engine(db)
    try:
        first = parts(engine=engine, plan_id=1)["items"][0]
    finally:
        engine.dispose()
    slot = next(op for op in first["operations"] if op["name"] == "slot")
    force = slot["measurements"]["force_N"]
    assert force["raw"]["quantity"] == "spindle_current_A"
    assert force["raw"]["uncertainty"] == 0.02  # MILLING_DEMO_UNCERTAINTY, as read
    assert 3.0 < force["raw"]["value"] < 6.0 and force["uncertainty"] > 1.0  # A in, N out


def test_default_plan_is_the_milling_part(monkeypatch, tmp_path):
    monkeypatch.chdir(ROOT)  # the default plans are relative to the repository, as in README
    db = f"sqlite:///{tmp_path / 'demo.db'}"
    result = CliRunner().invoke(app, ["demo", "--milling", "--json", "--parts", "2", "--db", db])
    assert result.exit_code == 0, result.output
    assert [op["name"] for op in json.loads(result.stdout)["operations"]] == ["slot", "side-finish"]


def test_no_violations_and_faster(milling_json):
    assert milling_json["violations"] == 0 and milling_json["parts"] == 20
    cycle = milling_json["cycle_time_min"]
    assert cycle["robust"] < cycle["catalog"]
    assert cycle["final"] < cycle["robust"]
    slot = _op(milling_json, "slot")
    assert set(slot["robust"]["setpoint"]) == {
        "axial_depth_mm",
        "radial_depth_mm",
        "feed_per_tooth_mm",
        "speed_m_min",
    }
    assert slot["final"]["mrr_cm3_min"] > slot["robust"]["mrr_cm3_min"]
    # the force limit binds at the upper band edge: F + ΔF = 230 N at the continuous optimum;
    # the setpoint on the machine's grid (0.001 mm, 0.0001 mm/tooth, 1 m/min) sits at most
    # a grid step below it: F ∝ ap · fz^0.695, one step of ap (of 1-4 mm) or fz (of about
    # 0.03 mm) is at most 0.1 % or 0.23 %
    for row in ("robust", "final"):
        force = slot[row]["predicted"]["force_N"]
        assert 230.0 * (1 - 0.0035) <= force["value"] + force["band"] <= 230.0


def test_force_is_measured_through_the_spindle_current(milling_json):
    # Kim & Jeon §6.2.3 at 4500 rpm: between the 300 and 450 mm/min lines the slope dF/dI is
    # interpolated, 1/5.981e-3 = 167.20 and 1/3.867e-3 = 258.60 N/A (as the plan rounds them,
    # to 0.01 N/A); the reading's 0.02 A
    # (MILLING_DEMO_UNCERTAINTY) becomes slope × 0.02 A of force, not the dynamometer's 3 N.
    slot = _op(milling_json, "slot")["robust"]
    feed = slot["predicted"]["feed_rate_mm_min"]["value"]
    w = (feed - 300.0) / 150.0
    slope = (1 - w) * 167.20 + w * 258.60
    assert slot["measured"]["force_N"]["uncertainty"] == pytest.approx(slope * 0.02, rel=1e-9)
    assert slot["measured"]["roughness_um"]["uncertainty"] == pytest.approx(0.05)


def test_force_model_follows_kim_and_jeon():
    derive = _derive()
    # Kim & Jeon §5, Fig. 5: F_max held at 160 N with d = 3.0 mm at 70 mm/min and d = 1.5 mm
    # at 190 mm/min (1500 rpm, two flutes: fz = f / 3000)
    assert derive.kim_jeon_max_force_N(3.0, 70 / 3000) == pytest.approx(160, rel=0.02)
    assert derive.kim_jeon_max_force_N(1.5, 190 / 3000) == pytest.approx(160, rel=0.02)
    k_slot, b, lo, hi = derive.slot_power_law()
    assert max(-lo, hi) < 0.005  # the power law stays within 0.5 % of Eq. 1 over the bounds
    x = derive.radial_exponent()
    assert x == pytest.approx(math.log(1000 / 600) / math.log(1 / 0.7))
    model = load_plan(PLAN).tools["EM10-2F"].models["force_N"]
    assert model.K == pytest.approx(k_slot / 10**x, abs=0.005)
    assert model.exponents["feed_per_tooth_mm"] == pytest.approx(b, abs=5e-4)
    assert model.exponents["radial_depth_mm"] == pytest.approx(x, abs=5e-4)
    assert model.dK / model.K == pytest.approx(0.25, abs=0.001)  # Kim & Jeon Table 1


LINEAR = LinearCurrentCalibration(offset_N=-591.37, slope_N_per_A=167.2, source="test")


@settings(max_examples=60, deadline=None)
@given(
    force=st.floats(1.0, 2000.0),
    feed=st.floats(150.0, 450.0),
    linear=st.booleans(),
)
def test_virtual_sensor_round_trip(force, feed, linear):
    calibration = LINEAR if linear else KIM_JEON_SPINDLE_FMAX_4500RPM
    context = {"spindle_speed_rpm": 4500.0, "feed_rate_mm_min": feed}
    reading = reading_for_force(calibration, force, context)
    back = to_force(calibration, "spindle_current_A", reading, 0.0, context).value
    assert back == pytest.approx(force, rel=1e-9, abs=1e-9)


def test_milling_demo_captures_most_of_the_oracles_gain(milling_json):
    # issue 15, decision 2, for --milling: (robust − final) / (robust − oracle) >= 0.75 and
    # no true-limit violation with the default strategy
    cycle = milling_json["cycle_time_min"]
    captured = (cycle["robust"] - cycle["final"]) / (cycle["robust"] - cycle["oracle"])
    assert milling_json["gain_captured"] == captured
    assert captured >= 0.75 and milling_json["violations"] == 0
