"""The fleet commands' options as a review of the fleet CLI (issue 32) found them.

- ``rcb plans create FILE --prior bogus`` said typer's and pydantic's message (``Invalid value
  for '--prior': Value error, 'bogus' is not one of 'fleet', 'catalogue'. (got 'bogus')``),
  not ``rcb``'s one line naming the option, its value and the choices (as ``--strategy``).
- ``rcb models export --help`` said it writes "every learn plan's posterior"; it writes the
  models in the fleet: each machine's newest plans, neither halted nor taken out.
- ``rcb models export TOOL --material M`` of a material the tool was not learned on named
  ``TOOL``, which was right, where ``--material`` was the wrong input (the field is decided
  in :func:`db.fleet_models.export_models`).
"""

from __future__ import annotations

from pathlib import Path

from test_fleet_db import _learned

from api.cli.main import app
from supervisor.fleet.window import PLANS_PER_MACHINE

from conftest import DEMO_PLAN, engine_url, invoke


def _said(done) -> str:  # type: ignore[no-untyped-def]
    return " ".join(done.output.split())


def test_an_unknown_prior_is_named_as_the_option_with_the_choices(runner, tmp_path) -> None:
    db = f"sqlite:///{tmp_path / 'none.db'}"  # refused before any database is opened
    done = invoke(runner, "plans", "create", str(DEMO_PLAN), "--prior", "bogus", "--db", db)
    assert done.exit_code == 2
    assert done.output == "rcb: error: --prior = 'bogus': must be one of fleet, catalogue\n"
    shown = runner.invoke(app, ["plans", "create", "--help"], env={"COLUMNS": "80"})
    assert "<fleet|catalogue>" in shown.output  # the choices, as --strategy shows its


def test_models_export_help_says_which_models_it_writes(runner) -> None:
    done = runner.invoke(app, ["models", "export", "--help"], env={"COLUMNS": "80"})
    assert done.exit_code == 0, done.output
    said = _said(done)
    assert "every learn plan" not in said
    assert f"Of each machine, its {PLANS_PER_MACHINE} newest learn plans with the tool" in said
    assert "neither halted nor taken out (rcb fleet exclude)" in said
    assert "the models it imported from other databases" in said


def test_an_export_on_a_material_not_learned_names_the_material(
    engine, runner, tmp_path: Path
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    out = tmp_path / "x.json"
    done = invoke(
        runner, "models", "export", "CNMG432RN", "--material", "titanium", "--out", str(out),
        "--db", engine_url(engine),
    )  # fmt: skip
    assert done.exit_code == 2 and not out.exists()
    assert _said(done).startswith(
        "rcb: error: --material = 'titanium': no learn plan of this database measured it on "
        "'titanium'; it was measured on 'AISI 1045 steel, cold rolled'"
    )
