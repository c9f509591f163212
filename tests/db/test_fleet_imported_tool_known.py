"""A tool this database knows only from imported models is a tool to ``rcb fleet``.

A review: a plant imported the learned models of a tool of another plant's own (stored there
with ``rcb tools add``, not in the catalogue): ``rcb models import`` stored them ("8 new") and
``rcb models export`` wrote them again, but ``rcb fleet imported``, ``show`` and ``law`` (and
``GET /tools/{name}/fleet…``) said ``TOOL = 'PLANT-A-1': no such tool in the catalogue or the
database``, so the engineer could not see which machines they came from, to take one out.
"""

from __future__ import annotations

import json

from test_fleet_db import _learned
from test_fleet_import_once import _second

from api.services.fleet_models import export_tool, import_tool

from conftest import engine_url, invoke

TOOL = "PLANT-A-1"


def test_a_tool_known_only_by_its_imported_models_is_listed(engine, tmp_path, runner) -> None:
    first = _second(tmp_path, "first")
    _learned(first, "fleet-a", 0, 3)
    document = export_tool(engine=first, tool="CNMG432RN")
    first.dispose()
    document["tool"] = TOOL  # the first plant's own tool, under its own name
    for item in document["learned"]:
        item["tool"]["name"] = TOOL
    assert import_tool(engine=engine, data=document, source="a.json").body["new"] == 2
    url = engine_url(engine)
    shown = invoke(runner, "fleet", "imported", TOOL, "--json", "--db", url)
    assert shown.exit_code == 0, shown.output
    machines = json.loads(shown.stdout)["machines"]
    assert [(m["models"], m["in_fleet"]) for m in machines] == [(2, True)]
    assert machines[0]["machine"].startswith("lathe-0@")
    members = invoke(runner, "fleet", "show", TOOL, "--json", "--db", url)
    assert members.exit_code == 0, members.output
    assert json.loads(members.stdout)["imported"] == 2
    law = invoke(runner, "fleet", "law", TOOL, "--json", "--db", url)
    assert law.exit_code == 0, law.output
    quantities = json.loads(law.stdout)["quantities"]
    assert {q["quantity"] for q in quantities} == {"force_N", "roughness_um"}
    assert all("prior from 1 plan on 1 machine" in q["text"] for q in quantities)
    unknown = invoke(runner, "fleet", "imported", "PLANT-A-2", "--db", url)
    assert unknown.exit_code == 2
    assert "TOOL = 'PLANT-A-2': no such tool" in unknown.output
