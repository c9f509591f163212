"""An imported plan counts as a plan of its own in a prior's provenance, whatever its name.

A review: two plants each ran a plan named ``fleet-a`` (one part program, one name at both
sites); the second imported the first's models and a new plan there said "prior from 1 plan
on 2 machines" (``plans_total`` 1, ``rcb fleet law`` the same), since an imported model's
machine was told apart by its database (``lathe-0@6f1c2a3b``) but its plan was not, and the
plans were counted by name. Now an imported plan is named as its machine is
(``fleet-a@6f1c2a3b``): 2 plans on 2 machines, on every surface.
"""

from __future__ import annotations

from test_fleet_db import LEARN, _body, _learned
from test_fleet_import_once import _second

from api.services.fleet_models import export_tool, import_tool
from api.services.plans import create_plan
from api.services.read.fleet import fleet_law
from db.fleet_imported import abroad


def test_a_plan_of_the_same_name_at_another_plant_is_another_plan(engine, tmp_path) -> None:
    first = _second(tmp_path, "first")
    _learned(first, "fleet-a", 0, 3)  # lathe-0 at the first plant
    document = export_tool(engine=first, tool="CNMG432RN")
    origin = document["learned"][0]["origin"]
    _learned(engine, "fleet-a", 1, 3)  # lathe-1 here, the same plan name
    assert import_tool(engine=engine, data=document, source="a.json").body["new"] == 2
    made = create_plan(engine=engine, body=_body("fleet-new", "lathe-3"), settings=LEARN).body
    line = made["provenance"]["rough-od"][0]
    assert (line["plans_total"], line["machines_total"]) == (2, 2), line
    assert line["plans"] == sorted(["fleet-a", abroad("fleet-a", origin)])
    assert line["machines"] == sorted(["lathe-1", abroad("lathe-0", origin)])
    assert "prior from 2 plans on 2 machines" in line["text"]
    law = fleet_law(engine=engine, tool="CNMG432RN")["quantities"][0]
    assert (law["plans"], law["machines"]) == (2, 2)
    assert "prior from 2 plans on 2 machines" in law["text"]
    # what this database exports names its imported plan as the first plant named it
    again = export_tool(engine=engine, tool="CNMG432RN")["learned"]
    theirs = [item for item in again if item["origin"] == origin]
    assert [item["plan"] for item in theirs] == ["fleet-a", "fleet-a"]
    first.dispose()
