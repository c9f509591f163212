"""``rcb models export`` of a tool whose every plan is out of the fleet says so.

A process engineer's review: with the only plans of a tool taken out (``rcb fleet exclude``),
``rcb models export`` said "no learn plan of this database measured it", where ``rcb fleet
show`` lists the plan that measured it and why it is out. It now sends the engineer there.
"""

from __future__ import annotations

from pathlib import Path

from test_fleet_db import _learned

from conftest import engine_url, invoke


def test_an_export_of_a_tool_whose_plans_are_out_says_where_to_look(
    engine, runner, tmp_path: Path
) -> None:
    _learned(engine, "fleet-a", 1, 2)
    url, out = engine_url(engine), tmp_path / "x.json"
    out_of = invoke(runner, "fleet", "exclude", "--plan", "fleet-a", "--reason", "x", "--db", url)
    assert out_of.exit_code == 0, out_of.output
    told = invoke(runner, "models", "export", "CNMG432RN", "--out", str(out), "--db", url)
    assert told.exit_code == 2 and not out.exists()
    assert " ".join(told.output.split()).endswith(
        "TOOL = 'CNMG432RN': no plan in the fleet learned it (rcb fleet show CNMG432RN: each "
        "plan and why)"
    )
    back = invoke(runner, "fleet", "include", "--plan", "fleet-a", "--db", url)
    assert back.exit_code == 0, back.output
    done = invoke(runner, "models", "export", "CNMG432RN", "--out", str(out), "--db", url)
    assert done.exit_code == 0 and out.exists(), done.output
