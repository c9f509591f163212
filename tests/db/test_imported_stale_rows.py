"""A model imported before today's checks names its machine and the way out (issue 32).

A review: rows ``rcb models import`` stored before it refused an operation without a bound
the model needs (``bounds.depth_mm``) or of another process are still in ``imported_models``.
Read back, each is refused, so every ``rcb plans create`` of the tool failed with
``imported_models.body.operation.bounds.depth_mm = None: missing``, an error naming no machine
and no command. It now names the imported machine as an engineer takes it out
(``lathe-7@0c5f0b7e``) and the command that does; taken out, the rows are not read and new
plans start from the rest of the fleet. Nothing is dropped unasked.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import pytest
from sqlalchemy import insert, select
from sqlalchemy.orm import Session
from test_fleet_db import LEARN, _body, _learned
from test_fleet_import_once import _rows, _second

from api.services.fleet_models import exclude_from_fleet, export_tool, import_tool
from api.services.plans import create_plan
from db import tables as t
from models.errors import InputError, InputErrors

#: The database that learned the stale rows (a UUID, as a document names one).
ORIGIN = "0c5f0b7e-5d1a-4c55-9f43-2b8f3b1a9e21"


def _no_depth(body: dict[str, Any]) -> None:
    del body["operation"]["bounds"]["depth_mm"]


def _milling(body: dict[str, Any]) -> None:
    body["operation"]["process"] = "milling"


def _stale(engine, machine: str, change: Callable[[dict[str, Any]], None]) -> None:  # type: ignore[no-untyped-def]
    """A row as an older ``rcb models import`` stored it: an item today's checks refuse."""
    with Session(engine) as session, session.begin():
        good = session.scalars(select(t.ImportedModel).order_by(t.ImportedModel.id)).first()
        assert good is not None
        body = copy.deepcopy(good.body)
        change(body)
        body["machine"] = machine
        row = {
            "tool": good.tool,
            "origin": ORIGIN,
            "machine": machine,
            "plan": "old-plan",
            "operation": good.operation,
            "quantity": good.quantity,
            "observations": good.observations,
            "body": body,
            "source": f"old.json: old-plan on {machine}",
        }
        session.execute(insert(t.core_table(t.ImportedModel)), [row])


@pytest.mark.parametrize(
    ("change", "field"),
    [(_no_depth, "operation.bounds.depth_mm"), (_milling, "operation.process")],
)
def test_a_stale_imported_row_names_its_machine_and_the_command_that_takes_it_out(
    engine, tmp_path, change, field
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    second = _second(tmp_path)
    import_tool(engine=second, data=export_tool(engine=engine, tool="CNMG432RN"), source="a.json")
    _stale(second, "lathe-7", change)
    assert _rows(second) == 3
    with pytest.raises(InputError) as refused:
        create_plan(engine=second, body=_body("new", "lathe-9"), settings=LEARN)
    err = refused.value
    assert not isinstance(err, InputErrors)  # one machine, one error
    assert err.field == f"imported_models.body.{field}"  # what is wrong, as before
    assert "lathe-7@0c5f0b7e" in err.reason  # whose model, as rcb fleet imported lists it
    assert "rcb fleet exclude --machine lathe-7@0c5f0b7e --reason TEXT" in err.reason
    assert "old.json" in err.reason  # where it came from
    # the catalogue's prior does not read the fleet: a plan can still be made
    made = create_plan(
        engine=second, body=_body("catalogue", "lathe-9"), settings=LEARN, prior="catalogue"
    )
    assert made.body["prior"] == "catalogue"
    # taken out as the error says, the stale rows are not read (nor dropped)
    exclude_from_fleet(
        engine=second, plan_id=None, machine="lathe-7@0c5f0b7e", reason="imported before checks"
    )
    fleet = create_plan(engine=second, body=_body("fleet", "lathe-9"), settings=LEARN).body
    assert fleet["prior"] == "fleet"
    lines = [p for ps in fleet["provenance"].values() for p in ps]
    assert {m for p in lines for m in p["machines"]} == {_abroad_of(engine, "lathe-0")}
    assert _rows(second) == 3
    second.dispose()


def test_two_stale_machines_are_named_together(engine, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    second = _second(tmp_path)
    import_tool(engine=second, data=export_tool(engine=engine, tool="CNMG432RN"), source="a.json")
    _stale(second, "lathe-7", _no_depth)
    _stale(second, "lathe-8", _milling)
    with pytest.raises(InputErrors) as refused:
        create_plan(engine=second, body=_body("new", "lathe-9"), settings=LEARN)
    named = [e.reason for e in refused.value.errors]
    assert len(named) == 2
    assert "--machine lathe-7@0c5f0b7e" in named[0] and "--machine lathe-8@0c5f0b7e" in named[1]
    second.dispose()


def _abroad_of(engine, machine: str) -> str:  # type: ignore[no-untyped-def]
    from db.fleet_imported import abroad
    from db.identity import database_id

    with Session(engine) as session:
        return abroad(machine, database_id(session=session))
