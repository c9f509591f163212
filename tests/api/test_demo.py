"""`rcb demo`: the paper's demonstration on the virtual lathe, end to end."""

from __future__ import annotations

import json

import pytest
from sqlalchemy.engine import make_url

from api.cli.main import app
from api.services.read.plans import list_plans
from api.services.read.setpoints import current_setpoints
from db.engine import make_engine
from supervisor.inputs.plan import load_plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.strategies import DEFAULT_STRATEGY
from supervisor.virtual.sampling import oracle_tools, sample_machine

from conftest import DEMO_PLAN


def _db(folder) -> list[str]:  # type: ignore[no-untyped-def]
    """``--db`` of a demonstration database in ``folder`` (not ./rcb-demo.db in the checkout)."""
    return ["--db", f"sqlite:///{folder / 'demo.db'}"]


@pytest.fixture(scope="module")
def demo_json(tmp_path_factory):
    from typer.testing import CliRunner

    db = _db(tmp_path_factory.mktemp("demo"))
    result = CliRunner().invoke(app, ["demo", "--json", "--plan", str(DEMO_PLAN), *db])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_demo_json_contract(demo_json):
    assert demo_json["parts"] == 20 and demo_json["strategy"] == DEFAULT_STRATEGY == "learn"
    names = [op["name"] for op in demo_json["operations"]]
    assert names[0] == "rough-od" and len(names) == 6
    for op in demo_json["operations"]:
        for row in ("catalog", "robust", "final"):
            assert set(op[row]) >= {"setpoint", "mrr_cm3_min", "predicted", "measured"}
    # Table 5 step 1 row C: 1.3 mm, 0.25 mm/rev, 187 m/min = 60.8 cm³/min (d·f·v)
    assert op_row(demo_json, "rough-od", "catalog")["mrr_cm3_min"] == pytest.approx(60.775)
    assert set(demo_json["cycle_time_min"]) == {"catalog", "robust", "final", "oracle"}


def test_demo_captures_most_of_the_oracles_gain(demo_json):
    # issue 15, decision 2: (robust − final) / (robust − oracle) >= 0.75 with 0 violations,
    # the oracle being the plan optimised with the virtual lathe's true models and no band
    plan = load_plan(DEMO_PLAN)
    oracle = optimize_plan(plan, oracle_tools(sample_machine(plan, demo_json["seed"])))
    cycle = demo_json["cycle_time_min"]
    assert cycle["oracle"] == pytest.approx(oracle.cycle_time_min, rel=1e-12)
    captured = (cycle["robust"] - cycle["final"]) / (cycle["robust"] - cycle["oracle"])
    assert demo_json["gain_captured"] == pytest.approx(captured)
    assert captured >= 0.75 and demo_json["violations"] == 0


def op_row(data, name, row):
    return next(op[row] for op in data["operations"] if op["name"] == name)


def test_demo_is_safe_and_faster_at_each_stage(demo_json):
    cycle = demo_json["cycle_time_min"]
    assert demo_json["violations"] == 0
    assert cycle["robust"] < cycle["catalog"]  # the robust start beats the catalogue
    assert cycle["final"] < cycle["robust"]  # RCB beats the robust start
    for op in demo_json["operations"]:  # never less productive than the robust start
        assert op["final"]["mrr_cm3_min"] >= op["robust"]["mrr_cm3_min"] * 0.98, op["name"]


def test_no_safe_controller_beats_the_oracle(demo_json):
    # The oracle (true models, no band) is the best any controller can do; with no true-limit
    # crossed, the final setpoints cannot remove material faster.
    plan = load_plan(DEMO_PLAN)
    oracle = optimize_plan(plan, oracle_tools(sample_machine(plan, demo_json["seed"])))
    assert demo_json["cycle_time_min"]["final"] >= oracle.cycle_time_min * (1 - 1e-6)


def test_demo_is_repeatable_and_seeded(runner, tmp_path):
    def run(seed: str) -> dict:  # type: ignore[type-arg]
        args = ["demo", "--json", "--parts", "3", "--seed", seed, *_db(tmp_path)]
        done = json.loads(runner.invoke(app, args).stdout)
        del done["stored"]  # a plan of its own each time: ivester-demo-part, -2, -3
        return done

    a, b, c = run("7"), run("7"), run("8")
    assert a == b and a != c


def test_demo_table_output(runner, tmp_path):
    result = runner.invoke(app, ["demo", "--parts", "2", *_db(tmp_path)], env={"COLUMNS": "140"})
    assert result.exit_code == 0, result.output
    assert "rough-od" in result.stdout and "cycle time" in result.stdout
    assert "vs catalogue" in result.stdout


@pytest.mark.parametrize("milling", [False, True])
def test_demo_says_first_what_its_rows_are(runner, tmp_path, milling):
    """C, R and final, model and meas., filled to 80 columns (before: C and R unexplained)."""
    args = ["demo", "--parts", "3", *(["--milling"] if milling else []), *_db(tmp_path)]
    result = runner.invoke(app, args, env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    first = result.stdout.split("\n\n")[0]
    assert all(len(line) <= 80 for line in first.splitlines()), first
    assert " ".join(first.split()).endswith(
        ", 3 parts. Per operation, C: the catalogue's parameters, R: the robust start, final: "
        "the setpoints after part 3; model: the prediction ± its band, meas.: the reading at "
        "those setpoints ± its uncertainty (the layout of Ivester & Heigel's Table 5)."
    )


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--strategy", "pid"], "--strategy = 'pid': must be one of"),
        (["--alpha", "0"], "--alpha = 0.0: must be a number in (0, 1]"),
        (["--parts", "0"], "--parts = 0: must be at least 1"),
        # numpy refused it after the plan was stored: a traceback and a plan of no parts
        (["--seed", "-1"], "rcb: error: --seed = -1: must be at least 0"),
        (["--seed", "99999999999999999999"], "--seed = 99999999999999999999: must be at most"),
    ],
)
def test_demo_bad_arguments(runner, tmp_path, args, needle):
    result = runner.invoke(app, ["demo", *args, *_db(tmp_path)])
    assert result.exit_code == 2
    assert needle in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "demo.db").exists()  # nothing stored


def test_the_demo_is_stored_as_plans_are_and_a_second_run_beside_the_first(runner, tmp_path):
    db = _db(tmp_path)
    first = json.loads(runner.invoke(app, ["demo", "--json", "--parts", "3", *db]).stdout)
    second = json.loads(runner.invoke(app, ["demo", "--json", "--parts", "2", *db]).stdout)
    names = [first["stored"]["name"], second["stored"]["name"]]
    assert names == ["ivester-demo-part", "ivester-demo-part-2"]
    engine = make_engine(db[1])
    try:
        listed = list_plans(engine=engine)["plans"]
        assert [(p["name"], p["parts"]) for p in listed] == [(names[0], 3), (names[1], 2)]
        in_force = current_setpoints(engine=engine, plan_id=first["stored"]["plan_id"])
    finally:
        engine.dispose()
    # what the demonstration ends on is what the database holds in force for the next part
    assert in_force["setpoint_version"] == first["setpoint_version"]
    shown = {op["name"]: op["final"]["setpoint"] for op in first["operations"]}
    assert {op["name"]: op["setpoint"] for op in in_force["operations"]} == shown


def test_the_demo_never_writes_to_the_plants_database(runner, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    plant = f"sqlite:///{tmp_path / 'plant.db'}"
    done = runner.invoke(app, ["demo", "--parts", "1"], env={"RCB_DATABASE_URL": plant})
    assert done.exit_code == 0, done.output
    assert (tmp_path / "rcb-demo.db").is_file() and not (tmp_path / "plant.db").exists()
    told = " ".join(line.strip() for line in done.stderr.splitlines())
    assert "rcb: stored in sqlite:///rcb-demo.db as plan 1 (ivester-demo-part)" in told
    assert all(len(line) <= 80 for line in done.stderr.splitlines())


def test_the_demo_never_prints_a_databases_password(runner, empty_postgres):
    # the local server trusts every connection: a password in the URL is accepted, and ignored
    url = make_url(empty_postgres).set(password="s3cret").render_as_string(hide_password=False)
    done = runner.invoke(app, ["demo", "--parts", "1", "--db", url, "--json"])
    assert done.exit_code == 0, done.output
    assert "s3cret" not in done.stdout + done.stderr
    assert ":***@" in json.loads(done.stdout)["stored"]["database"]
    shown = runner.invoke(app, ["demo", "--parts", "1", "--db", url])
    assert shown.exit_code == 0 and "s3cret" not in shown.stdout + shown.stderr
