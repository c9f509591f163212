"""rcb plans / history / parts / export over a stored plan (SQLite)."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from test_service import BODY, _reports

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine

from migrated import migrated


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    url = f"sqlite:///{tmp_path_factory.mktemp('review') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    bodies, state = _reports(4)
    answers = [
        report_part(engine=engine, plan_id=plan_id, report=parse_report(b)).body for b in bodies
    ]
    engine.dispose()
    return url, plan_id, bodies, answers, state


def _json(runner, *args):
    result = runner.invoke(app, [*args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_plans_and_history_show_what_is_stored(runner, stored):
    url, plan_id, bodies, answers, state = stored
    plans = _json(runner, "plans", "--db", url)["plans"]
    assert [(p["id"], p["parts"], p["setpoint_version"]) for p in plans] == [
        (plan_id, 4, state.version)
    ]
    history = _json(runner, "history", str(plan_id), "--db", url)
    versions = history["versions"]
    assert versions[0]["cause"] == "initial"
    # Ivester & Heigel Table 5 step 1 R: 191.2 cm³/min at the robust start
    assert versions[0]["operations"][0]["mrr_cm3_min"] == pytest.approx(191.2, rel=0.005)
    keys = ("name", "tool", "setpoint", "predicted", "mrr_cm3_min", "time_min", "binding")
    last = [{k: op[k] for k in keys} for op in versions[-1]["operations"]]
    assert last == [{k: op[k] for k in keys} for op in answers[-1]["operations"]]
    moved = [v for v in versions if v["cause"] == "part"]
    assert all(v["decisions"] for v in moved)  # each version shows the decisions behind it
    one = _json(runner, "history", str(plan_id), "--operation", "rough-od", "--db", url)
    assert {len(v["operations"]) for v in one["versions"]} == {1}


def test_parts_and_export_round_trip(runner, stored, tmp_path):
    url, plan_id, bodies, answers, _ = stored
    parts = _json(runner, "parts", str(plan_id), "--db", url)["parts"]
    assert [p["serial"] for p in parts] == [b["serial"] for b in bodies]
    sent = bodies[0]["operations"][0]["measurements"]["force_N"]
    got = parts[0]["operations"][0]["measurements"]["force_N"]
    assert (got["value"], got["uncertainty"]) == (sent["value"], sent["uncertainty"])
    future = _json(runner, "parts", str(plan_id), "--since", "2999-01-01", "--db", url)
    assert future["parts"] == []
    # an age, as rcb audit --since takes: the parts just stored are within the last hour
    recent = _json(runner, "parts", str(plan_id), "--since", "60m", "--db", url)["parts"]
    assert [p["serial"] for p in recent] == [b["serial"] for b in bodies]
    for fmt in ("csv", "parquet"):
        out = tmp_path / fmt
        result = runner.invoke(
            app, ["export", str(plan_id), "--format", fmt, "--out", str(out), "--db", url]
        )
        assert result.exit_code == 0, result.output
        read = pd.read_csv if fmt == "csv" else pd.read_parquet
        m = read(out / f"measurements.{fmt}")
        assert len(m) == sum(len(op["measurements"]) for b in bodies for op in b["operations"])
        row = m[(m.serial == bodies[0]["serial"]) & (m.operation == "rough-od")]
        assert row[row.quantity == "force_N"].value.iloc[0] == pytest.approx(sent["value"])
        s = read(out / f"setpoints.{fmt}")
        assert set(s.version) == set(range(1, len(answers) + 2))
        assert {"depth_mm", "feed_mm_rev", "speed_m_min", "force_N", "force_N_band"} <= set(s)
        d = read(out / f"decisions.{fmt}")
        assert len(d) == sum(len(a["updates"]) for a in answers)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["history", "99"], "PLAN = 99: no plan with id 99 (rcb plans lists them)"),
        (["parts", "1", "--since", "yesterday"], "--since = 'yesterday': expected an age"),
        (["parts", "1", "--since", "0d"], "--since = '0d': more than 0"),
        (  # in the year 10000 in UTC: a traceback (OverflowError) before
            ["parts", "1", "--since", "9999-12-31T23:59:59-05:00"],
            "--since = '9999-12-31T23:59:59-05:00': outside the years 1 to 9999 in UTC",
        ),
        (["history", "1", "--operation", "nope"], "--operation = 'nope'"),
        (["export", "1", "--format", "xlsx", "--out", "x"], "--format = 'xlsx'"),
    ],
)
def test_review_commands_refuse_bad_input(runner, stored, args, message):
    url = stored[0]
    result = runner.invoke(app, [*args, "--db", url])
    assert result.exit_code == 2 and message in result.stderr
    assert "Traceback" not in result.output


def test_history_parts_and_export_show_the_numbers_stored(runner, stored, tmp_path):
    """Every measurement and every setpoint as the database holds them, through each view."""
    from sqlalchemy import select
    from sqlalchemy.orm import Session

    from db import tables as t

    url, plan_id, *_ = stored
    engine = make_engine(url)
    with Session(engine) as session:
        measured = {
            (serial, op, m.quantity): (m.value, m.uncertainty)
            for m, serial, op in session.execute(
                select(t.Measurement, t.Part.serial, t.Operation.name)
                .join(t.Part, t.Measurement.part_id == t.Part.id)
                .join(t.Operation, t.Measurement.operation_id == t.Operation.id)
            )
        }
        setpoints = {
            (version, op): (sp.parameters, sp.mrr_cm3_min)
            for sp, version, op in session.execute(
                select(t.Setpoint, t.SetpointVersion.version, t.Operation.name)
                .join(t.SetpointVersion, t.Setpoint.setpoint_version_id == t.SetpointVersion.id)
                .join(t.Operation, t.Setpoint.operation_id == t.Operation.id)
            )
        }
    engine.dispose()
    parts = _json(runner, "parts", str(plan_id), "--db", url)["parts"]
    shown = {
        (p["serial"], op["name"], q): (m["value"], m["uncertainty"])
        for p in parts
        for op in p["operations"]
        for q, m in op["measurements"].items()
    }
    assert shown == measured
    history = _json(runner, "history", str(plan_id), "--db", url)["versions"]
    listed = {
        (v["version"], op["name"]): (op["setpoint"], op["mrr_cm3_min"])
        for v in history
        for op in v["operations"]
    }
    assert listed == setpoints
    out = tmp_path / "csv"
    assert (
        runner.invoke(app, ["export", str(plan_id), "--out", str(out), "--db", url]).exit_code == 0
    )
    m = pd.read_csv(out / "measurements.csv")
    exported = {
        (r.serial, r.operation, r.quantity): (r.value, r.uncertainty) for r in m.itertuples()
    }
    assert exported.keys() == measured.keys()
    for key, (value, u) in measured.items():  # CSV keeps 15+ significant digits
        assert exported[key] == pytest.approx((value, u), rel=1e-12)
    s = pd.read_csv(out / "setpoints.csv")
    for r in s.itertuples():
        parameters, mrr = setpoints[(r.version, r.operation)]
        assert r.mrr_cm3_min == pytest.approx(mrr, rel=1e-12)
        assert r.depth_mm == pytest.approx(parameters["depth_mm"], rel=1e-12)
