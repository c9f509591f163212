"""``rcb models import`` refuses one plan listed on two machines (issue 32).

A plan runs on one machine (``plans.machine_id``; a database names a plan once), so an export
lists each plan's models under its machine. A hand-edited document that moved one of a plan's
items to another machine was stored: the fleet counted one plan on two machines, its readings
split between them, the between-machine spread learned from a plan compared with itself. The
item is now refused, naming it and its field; so is an item whose plan an earlier import
stored on another machine. Nothing is stored.
"""

from __future__ import annotations

import copy

import pytest
from test_fleet_db import _learned
from test_fleet_import_once import _rows, _second

from api.services.fleet_models import export_tool, import_tool
from models.errors import InputError


def test_one_plan_on_two_machines_is_refused(engine, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    document = export_tool(engine=engine, tool="CNMG432RN")
    assert [i["machine"] for i in document["learned"]] == ["lathe-0", "lathe-0"]
    bad = copy.deepcopy(document)
    bad["learned"][1]["machine"] = "lathe-5"  # fleet-a's second quantity, another machine
    second = _second(tmp_path)
    with pytest.raises(InputError) as refused:
        import_tool(engine=second, data=bad, source="edited.json")
    err = refused.value
    assert (err.field, err.value) == ("document.learned[1].machine", "lathe-5")
    assert "plan 'fleet-a'" in err.reason and "learned[0] is on 'lathe-0'" in err.reason
    assert _rows(second) == 0
    assert import_tool(engine=second, data=document, source="a.json").body["new"] == 2
    second.dispose()


def test_a_plan_stored_on_another_machine_is_refused(engine, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    document = export_tool(engine=engine, tool="CNMG432RN")
    second = _second(tmp_path)
    import_tool(engine=second, data=document, source="a.json")
    moved = copy.deepcopy(document)
    for item in moved["learned"]:
        item["machine"] = "lathe-5"
    with pytest.raises(InputError) as refused:
        import_tool(engine=second, data=moved, source="moved.json")
    err = refused.value
    assert (err.field, err.value) == ("document.learned[0].machine", "lathe-5")
    assert "stored on 'lathe-0' (a.json" in err.reason
    assert _rows(second) == 2
    # the same plan name from another database is another plan: stored
    other = copy.deepcopy(moved)
    for item in other["learned"]:
        item["origin"] = "0c5f0b7e-5d1a-4c55-9f43-2b8f3b1a9e21"
    assert import_tool(engine=second, data=other, source="b.json").body["new"] == 2
    second.dispose()
