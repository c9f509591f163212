"""``rcb fleet show`` says new plans start from the catalogue when every imported machine is out.

A review: with no stored plan of a tool and each machine of its imported models taken out
(``rcb fleet exclude --machine lathe-0@6f1c2a3b``), ``rcb fleet show`` still said "new plans
start from the imported models", where ``rcb fleet law`` said they start from the catalogue
and ``rcb plans create --prior fleet`` refused for want of a fleet. ``imported_in_fleet``
(``GET /tools/{name}/fleet``) counts the imported models of machines not taken out.
"""

from __future__ import annotations

import json

from test_fleet_db import _learned
from test_fleet_import_once import _second

from api.services.fleet_models import export_tool, import_tool

from conftest import engine_url, invoke


def _said(done) -> str:  # type: ignore[no-untyped-def]
    return " ".join(done.output.split())


def test_imported_machines_all_taken_out_leave_the_catalogue(engine, tmp_path, runner) -> None:
    first = _second(tmp_path, "first")
    _learned(first, "fleet-a", 0, 2)
    document = export_tool(engine=first, tool="CNMG432RN")
    first.dispose()
    assert import_tool(engine=engine, data=document, source="a.json").body["new"] == 2
    url = engine_url(engine)
    machine = json.loads(
        invoke(runner, "fleet", "imported", "CNMG432RN", "--json", "--db", url).stdout
    )["machines"][0]["machine"]
    shown = invoke(runner, "fleet", "show", "CNMG432RN", "--db", url)
    assert "new plans start from the imported models" in _said(shown)
    assert "and 2 learned models imported from other databases; their machines" in _said(shown)
    out = invoke(runner, "fleet", "exclude", "--machine", machine, "--reason", "x", "--db", url)
    assert out.exit_code == 0, out.output
    shown = invoke(runner, "fleet", "show", "CNMG432RN", "--db", url)
    assert shown.exit_code == 0, shown.output
    assert "no stored plan uses CNMG432RN: new plans start from the catalogue" in _said(shown)
    assert "and 2 learned models imported from other databases (0 of them in the fleet)" in (
        _said(shown)
    )
    told = [line for line in shown.output.splitlines() if not line.startswith("  rcb ")]
    assert max(len(line) for line in told) <= 80, shown.output  # a command alone may be longer
    page = json.loads(invoke(runner, "fleet", "show", "CNMG432RN", "--json", "--db", url).stdout)
    assert (page["imported"], page["imported_in_fleet"]) == (2, 0)
    back = invoke(runner, "fleet", "include", "--machine", machine, "--db", url)
    assert back.exit_code == 0, back.output
    page = json.loads(invoke(runner, "fleet", "show", "CNMG432RN", "--json", "--db", url).stdout)
    assert (page["imported"], page["imported_in_fleet"]) == (2, 2)
