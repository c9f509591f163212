"""An import's audit entry says what it did (issue 32, ``rcb models import``).

A review: ``rcb audit`` showed an import as ``import models  a.json  201`` and nothing else;
whether it stored four models or none (a file imported again) was only in the answer the
importer saw. The entry's detail now holds the counts the import reports.
"""

from __future__ import annotations

from sqlalchemy.orm import Session
from test_fleet_db import _learned
from test_fleet_import_once import _second

from api.services.fleet_models import export_tool, import_tool
from db.audit_read import AuditQuery, entries

COUNTS = ("stored", "new", "replaced", "kept", "own", "copied")


def _imports(engine) -> list[dict]:  # type: ignore[no-untyped-def,type-arg]
    with Session(engine) as session:
        found = entries(
            session=session, query=AuditQuery(action="import models"), below=None, limit=10
        )
    return list(reversed(found))  # oldest first


def test_an_imports_audit_entry_holds_its_counts(engine, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    document = export_tool(engine=engine, tool="CNMG432RN")
    second = _second(tmp_path)
    first = import_tool(engine=second, data=document, source="a.json").body
    again = import_tool(engine=second, data=document, source="a.json").body
    logged = _imports(second)
    assert [(e["target"], e["result"]) for e in logged] == [("a.json", "201")] * 2
    assert [e["detail"] for e in logged] == [
        {k: first[k] for k in COUNTS},
        {k: again[k] for k in COUNTS},
    ]
    assert logged[0]["detail"]["new"] == 4 and logged[1]["detail"]["kept"] == 4
    second.dispose()
