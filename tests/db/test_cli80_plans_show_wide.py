"""``rcb plans create`` and ``show`` of a plan with long names fit 80 columns, words whole.

A review of the fleet CLI (issue 32): with a plan's, its machine's and two operations' names
64 characters long, the status line (``rcb: plan 3 NAME on MACHINE: running``) ran past 80
columns; and a fleet-prior table whose serial in "let go by" (or a name) holds a digit, taken
for a number never folded, was fitted by folding the other columns' words
(``finish-groove`` / ``s``). Names and serials are folded first now, and only where they are
longer than their column.
"""

from __future__ import annotations

import json

from test_fleet_db import LEARN, _body, _learned

from api.cli.main import app
from api.services.plans import create_plan

from conftest import engine_url

#: Names at the identity length the review tried: 64 characters, a digit in the operations'.
PLAN, MACHINE = "p" * 39 + "-of-the-bearing-housing-a", "m" * 41 + "-five-axis-turning-cell"
LONG_OPS = ("rough-od-of-the-main-bearing-seat-before-heat-treatment-stages-1", "g" * 62 + "-2")


def test_a_plan_with_long_names_is_shown_in_80_columns(engine, runner, tmp_path) -> None:
    assert {len(PLAN), len(MACHINE), *map(len, LONG_OPS)} == {64}
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    body = _body(PLAN, MACHINE)
    for op, name in zip(body["operations"], LONG_OPS, strict=False):
        op["name"] = name
    file = tmp_path / "long.json"
    file.write_text(json.dumps(body), encoding="utf-8")
    url = engine_url(engine)
    created = runner.invoke(
        app,
        ["plans", "create", str(file), "--strategy", "learn", "--prior", "fleet", "--db", url],
        env={"COLUMNS": "80"},
    )
    assert created.exit_code == 0, created.output
    assert max(len(line) for line in created.output.splitlines()) <= 80, created.output
    assert f"rcb: plan 3 {PLAN}: setpoint version 1, cycle time" in " ".join(created.output.split())
    done = runner.invoke(app, ["plans", "show", PLAN, "--db", url], env={"COLUMNS": "80"})
    assert done.exit_code == 0, done.output
    lines = done.output.splitlines()
    assert max(len(line) for line in lines) <= 80, done.output
    said = " ".join(done.output.split())
    assert f"rcb: plan 3 {PLAN} on {MACHINE}: running" in said
    prior = lines[next(i for i, line in enumerate(lines) if "fleet prior" in line) :]
    words = {word for line in prior for word in line.split()}
    # the short names and the quantities whole, each in its row of the fleet-prior table
    assert {"force_N", "roughness_um", "rough-contour", "finish-od", "finish-grooves"} <= words
    assert {"quantity", "plans", "machines", "readings"} <= words  # headings whole
    # a name longer than its column is folded, never cut: its pieces make it whole again
    assert all(name in "".join(line.split()[0] for line in prior if line) for name in LONG_OPS)


#: A serial as an MES may send it: as long as a name, digits in it (read as a number).
SERIAL = "SN-" + "0" * 53 + "-1234567"


def test_a_long_serial_that_let_a_prior_go_folds_before_the_names(
    engine, runner, monkeypatch
) -> None:
    from api.services.read import plans as read_plans

    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    create_plan(engine=engine, body=_body("fleet-c", "lathe-3"), settings=LEARN, prior="fleet")
    stored = read_plans.get_plan

    def let_go(**given: object) -> dict[str, object]:  # rough-od's force_N let go by SERIAL
        data = stored(**given)  # type: ignore[arg-type]
        line = data["provenance"]["rough-od"][0]
        line["widened_by_part"] = SERIAL
        line["text"] += f"; let go by part {SERIAL}: this machine lies outside the spread"
        return data

    monkeypatch.setattr(read_plans, "get_plan", let_go)
    done = runner.invoke(
        app, ["plans", "show", "fleet-c", "--db", engine_url(engine)], env={"COLUMNS": "80"}
    )
    assert done.exit_code == 0, done.output
    lines = done.output.splitlines()
    assert max(len(line) for line in lines) <= 80, done.output
    prior = lines[next(i for i, line in enumerate(lines) if "fleet prior" in line) :]
    words = {word for line in prior for word in line.split()}
    names = ("rough-od", "rough-grooves", "finish-contour", "force_N", "roughness_um")
    assert set(names) <= words
    assert f"let go by part {SERIAL}: this machine lies outside the spread" in " ".join(prior)
