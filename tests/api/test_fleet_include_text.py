"""``rcb fleet law`` and ``rcb fleet show`` say what they show, in 80 columns.

Before, ``fleet law`` called the point where the machines' readings pin the law best
(:func:`supervisor.fleet.hierarchy.best_determined`) "where the fleet cut", and rich wrapped a
number away from its unit (``spread 4.1`` at a line's end, ``%,`` on the next); ``fleet show``
printed an empty table's header before saying no stored plan used the tool, and a 113-column
line on a database holding only imported models.
"""

from __future__ import annotations

import io
import json
import re

from rich.console import Console
from sqlalchemy import func, select
from sqlalchemy.orm import Session
from test_fleet_db import _learned

from api.cli.fleet import _print_filled
from api.cli.main import app
from api.services.fleet_models import export_tool, import_tool
from db import tables as t
from db.engine import make_engine

from conftest import engine_url, invoke
from migrated import migrated

COLUMNS = {"COLUMNS": "80"}


def _lines(output: str) -> list[str]:
    """The lines that must fit 80 columns: not a command printed whole on its own, to copy
    (its ``--db`` path may be longer than a line; ``api.cli.common.say_command``)."""
    return [line for line in output.splitlines() if not line.startswith("  rcb ")]


def test_a_number_stays_with_its_unit_and_its_sign_whatever_the_width() -> None:
    text = (
        "VCMR331 force_N: prior from 2 plans on 2 machines, between-machine spread 4.1 %, "
        "between operations 1.4 %, Y is known to ± 2.9 %, a new machine's to ± 15.2 %"
    )
    for width in range(16, 81):  # the longest word, between-machine, is 15
        out = io.StringIO()
        _print_filled(Console(file=out, width=width), text)
        lines = out.getvalue().splitlines()
        assert " ".join(lines) == text  # every word, no space lost or doubled
        assert not any(line.startswith("%") or line.endswith("±") for line in lines), width
        assert all(len(line) <= width for line in lines), width


def test_fleet_law_names_the_point_truthfully_in_80_columns(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    done = runner.invoke(
        app,
        ["fleet", "law", "CNMG432RN", "--db", engine_url(engine)],
        env=COLUMNS,
    )
    assert done.exit_code == 0, done.output
    lines = _lines(done.output)
    assert all(len(line.rstrip()) <= 80 for line in lines)
    assert "Where the fleet cut" not in done.output
    text = " ".join(done.output.split())
    wheres = re.findall(
        r"Where the machines' readings pin the law best \(depth_mm ([0-9.]+), feed_mm_rev "
        r"([0-9.]+), speed_m_min ([0-9.]+)\), on a new edge, Y is known to ± [0-9.]+ %",
        text,
    )
    law = json.loads(
        invoke(runner, "fleet", "law", "CNMG432RN", "--db", engine_url(engine), "--json").stdout
    )
    assert len(wheres) == len(law["quantities"]) == 2  # force and roughness
    for found, quantity in zip(wheres, law["quantities"], strict=True):
        reference = quantity["reference"]
        assert [float(v) for v in found] == [
            float(f"{reference[name]:.4g}") for name in ("depth_mm", "feed_mm_rev", "speed_m_min")
        ]
    assert not any(re.match(r"\s*%", line) or line.rstrip().endswith("±") for line in lines)


def test_fleet_show_of_a_tool_no_plan_used_prints_no_empty_table(engine, runner) -> None:
    done = invoke(runner, "fleet", "show", "CPGM32505", "--db", engine_url(engine))
    assert done.exit_code == 0
    assert done.output.strip() == (
        "rcb: no stored plan uses CPGM32505: new plans start from the catalogue"
    )


def test_fleet_show_of_imported_models_only_fits_80_columns(engine, runner, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    url = f"sqlite:///{tmp_path / 'plant2.db'}"
    migrated(url)
    plant2 = make_engine(url)
    import_tool(engine=plant2, data=export_tool(engine=engine, tool="CNMG432RN"), source="a.json")
    with Session(plant2) as session:
        held = session.scalar(select(func.count()).select_from(t.ImportedModel))
    done = invoke(runner, "fleet", "show", "CNMG432RN", "--db", url)
    plant2.dispose()
    assert done.exit_code == 0
    assert "the plans using it" not in done.output and "──" not in done.output
    assert all(len(line) <= 80 for line in _lines(done.output))
    assert " ".join(done.output.split()) == (
        "rcb: no stored plan uses CNMG432RN: new plans start from the imported models "
        f"rcb: and {held} learned models imported from other databases; their machines: "
        f"rcb fleet imported CNMG432RN --db {url}"  # the database it read (a review)
    )
    assert held == 4  # two plans, force and roughness each
