"""What ``rcb models export`` and ``rcb fleet exclude`` say of a name they do not hold.

A process engineer's review: ``models export NOPE`` said no learn plan measured it where
``fleet show NOPE`` says there is no such tool; ``--material`` spelt in another case gave no
hint of the material stored; ``fleet exclude --machine lathe-1`` on a database that holds
only another plant's ``lathe-1@6f1c2a3b`` gave no hint of the name it goes by here.
"""

from __future__ import annotations

import uuid
from pathlib import Path

from test_fleet_db import _learned
from test_fleet_import_once import _second

from api.services.fleet_models import export_tool, import_tool

from conftest import engine_url, invoke


def test_an_unknown_tool_material_or_machine_is_told_what_there_is(
    engine, runner, tmp_path: Path
) -> None:
    _learned(engine, "fleet-a", 1, 2)
    url, out = engine_url(engine), str(tmp_path / "x.json")
    nope = invoke(runner, "models", "export", "NOPE", "--out", out, "--db", url)
    assert nope.exit_code == 2
    assert "TOOL = 'NOPE': no such tool in the catalogue or the database" in nope.output
    told = invoke(
        runner, "models", "export", "CNMG432RN", "--out", out, "--db", url, "--material", "aisi"
    )
    assert told.exit_code == 2 and not Path(out).exists()
    assert told.output.strip().endswith(
        "no learn plan of this database measured it on 'aisi'; it was measured on "
        "'AISI 1045 steel, cold rolled'"
    )
    document = export_tool(engine=engine, tool="CNMG432RN")
    origin = str(uuid.uuid4())
    for item in document["learned"]:
        item["origin"] = origin
    second = _second(tmp_path)
    import_tool(engine=second, data=document, source="plant1.json")
    excluded = invoke(
        runner,
        "fleet",
        "exclude",
        "--machine",
        "lathe-1",
        "--reason",
        "x",
        "--db",
        engine_url(second),
    )
    second.dispose()
    assert excluded.exit_code == 2
    assert excluded.output.strip().endswith(
        f"no stored plan or imported model is of this machine here; imported machines are "
        f"named NAME@ORIGIN: lathe-1@{origin[:8]}?"
    )
