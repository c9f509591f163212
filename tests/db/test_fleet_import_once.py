"""Each imported learned model counts once (issue 32, ``rcb models import``; alembic 0020).

Before, every import stored every item again: the same file imported twice, a newer export of
the same plans, or a plant's own models sent back by a second plant were counted two or three
times in each new plan's fleet prior, which then claimed readings it did not have.
"""

from __future__ import annotations

import copy
import json
import uuid

from sqlalchemy import func, select, text
from sqlalchemy.orm import Session
from test_fleet_db import LEARN, _body, _learned, _made
from test_migration_0012 import _downgrade
from test_migrations import _no_difference

from api.cli.main import app
from api.services.fleet_models import export_tool, import_tool
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine, upgrade
from db.identity import database_id
from db.tables import utcnow
from models.errors import InputError

from migrated import migrated


def _second(tmp_path, name: str = "second"):  # type: ignore[no-untyped-def]
    """Another plant's database: SQLite at head, an identity of its own."""
    url = f"sqlite:///{tmp_path / f'{name}.db'}"
    migrated(url)
    return make_engine(url)


def _rows(engine) -> int:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        return int(session.scalar(select(func.count()).select_from(t.ImportedModel)) or 0)


def _prior(engine, name: str) -> dict:  # type: ignore[no-untyped-def,type-arg]
    made = create_plan(engine=engine, body=_body(name, "lathe-9"), settings=LEARN).body
    return {"provenance": made["provenance"], "operations": made["operations"]}


def test_a_document_imported_twice_counts_once(engine, tmp_path, runner) -> None:
    _learned(engine, "fleet-a", 0, 3)
    _learned(engine, "fleet-b", 1, 3)
    document = export_tool(engine=engine, tool="CNMG432RN")
    once, twice = _second(tmp_path, "once"), _second(tmp_path, "twice")
    first = import_tool(engine=once, data=document, source="a.json").body
    assert (first["stored"], first["new"], first["kept"]) == (4, 4, 0)  # 2 plans x 2 quantities
    for _ in range(2):
        import_tool(engine=twice, data=document, source="a.json")
    again = import_tool(engine=twice, data=document, source="a.json").body
    assert (again["stored"], again["kept"]) == (0, 4)
    assert _rows(twice) == _rows(once) == 4
    shown = runner.invoke(app, ["fleet", "show", "CNMG432RN", "--db", str(twice.url)])
    assert shown.exit_code == 0
    assert "and 4 learned models imported from other databases" in " ".join(shown.output.split())
    assert "no stored plan uses CNMG432RN: new plans start from the imported models" in (
        shown.output
    )
    assert _prior(twice, "new-plan") == _prior(once, "new-plan")  # 12 readings, not 36
    once.dispose()
    twice.dispose()


def test_a_newer_export_replaces_the_older_and_an_older_one_does_not(engine, tmp_path) -> None:
    a = _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    older = export_tool(engine=engine, tool="CNMG432RN")
    _made(engine, a, 0, "fleet-a-more", 3)  # plan a learns on
    newer = export_tool(engine=engine, tool="CNMG432RN")
    both, only = _second(tmp_path, "both"), _second(tmp_path, "only")
    import_tool(engine=both, data=older, source="older.json")
    done = import_tool(engine=both, data=newer, source="newer.json").body
    assert (done["new"], done["replaced"], done["kept"]) == (0, 2, 2)  # plan a's 2 quantities
    done = import_tool(engine=both, data=older, source="older.json").body  # late, and older
    assert (done["stored"], done["kept"]) == (0, 4)
    import_tool(engine=only, data=newer, source="newer.json")
    assert _rows(both) == 4
    # a document of plan a alone, the same origin: b's rows are left as they are
    alone = {**newer, "learned": [i for i in newer["learned"] if i["plan"] == "fleet-a"]}
    done = import_tool(engine=both, data=alone, source="alone.json").body
    assert (done["stored"], done["kept"]) == (0, 2) and _rows(both) == 4
    assert _prior(both, "new-plan") == _prior(only, "new-plan")
    both.dispose()
    only.dispose()


def test_a_plants_own_models_sent_back_are_skipped(engine, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    before = _prior(engine, "before")
    second = _second(tmp_path)
    import_tool(engine=second, data=export_tool(engine=engine, tool="CNMG432RN"), source="1.json")
    back = export_tool(engine=second, tool="CNMG432RN")  # only what it imported
    with Session(engine) as session:  # the first plant's identity, kept by the second
        assert {item["origin"] for item in back["learned"]} == {database_id(session=session)}
    done = import_tool(engine=engine, data=back, source="2.json").body
    assert (done["stored"], done["own"]) == (0, 2)
    assert _rows(engine) == 0
    assert _prior(engine, "after") == before
    second.dispose()


def test_a_version_1_document_imports_once_and_a_version_2_needs_its_origin(
    engine, tmp_path
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    document = export_tool(engine=engine, tool="CNMG432RN")
    old = copy.deepcopy(document)
    old["format"] = "rcb-fleet-models/1"
    for item in old["learned"]:
        del item["origin"]
    second = _second(tmp_path)
    assert import_tool(engine=second, data=old, source="v1.json").body["new"] == 2
    assert import_tool(engine=second, data=old, source="v1.json").body["kept"] == 2
    with Session(second) as session:
        assert set(session.scalars(select(t.ImportedModel.origin))) == {""}
    del document["learned"][1]["origin"]
    try:
        import_tool(engine=second, data=document, source="bad.json")
        raise AssertionError("a version 2 item without its origin was stored")
    except InputError as err:
        assert err.field == "document.learned[1].origin"
    assert _rows(second) == 2
    document["learned"][1]["origin"] = "0c5f0b7e-5d1a-4c55-9f43-2b8f3b1a9e21"
    document["learned"][0]["machine"] = "m" * 201  # more than its column holds
    try:
        import_tool(engine=second, data=document, source="long.json")
        raise AssertionError("a machine name longer than 200 characters was stored")
    except InputError as err:
        assert (err.field, err.reason) == (
            "document.learned[0].machine",
            "must be at most 200 characters",
        )
    assert _rows(second) == 2
    second.dispose()


#: imported_models rows as 0019 stored them: (machine, plan, operation, quantity, readings)
OLD = (
    ("lathe-1", "a", "rough-od", "force_N", 6),
    ("lathe-1", "a", "rough-od", "force_N", 9),  # the same model, a newer export: kept
    ("lathe-1", "a", "rough-od", "force_N", 3),
    ("lathe-2", "b", "rough-od", "force_N", 6),
)


def test_0020_keeps_one_row_per_model_and_names_the_database(backend_url) -> None:
    upgrade(backend_url, "0019")
    engine = make_engine(backend_url)
    with engine.begin() as connection:
        for machine, plan, op, quantity, readings in OLD:
            body = {
                "machine": machine,
                "plan": plan,
                "operation": {"name": op},
                "posterior": {"quantity": quantity, "observations": readings},
            }
            connection.execute(
                text(
                    "INSERT INTO imported_models (tool, body, source, imported_at)"
                    " VALUES ('CNMG432RN', :body, 'f.json', :now)"
                ),
                {"body": json.dumps(body), "now": utcnow()},
            )
    engine.dispose()
    upgrade(backend_url)
    engine = make_engine(backend_url)
    with engine.connect() as connection:
        kept = connection.execute(
            text(
                "SELECT origin, machine, plan, operation, quantity, observations"
                " FROM imported_models ORDER BY machine"
            )
        ).all()
        identity = connection.execute(text("SELECT id, uuid FROM database_identity")).all()
    engine.dispose()
    assert [tuple(row) for row in kept] == [
        ("", "lathe-1", "a", "rough-od", "force_N", 9),
        ("", "lathe-2", "b", "rough-od", "force_N", 6),
    ]
    assert len(identity) == 1 and identity[0][0] == 1 and uuid.UUID(identity[0][1])
    _no_difference(backend_url)
    _downgrade(backend_url, "0019")


def test_a_machine_of_the_same_name_in_another_plant_is_another_machine(engine, tmp_path) -> None:
    """Plant 1's lathe-0 and plant 2's lathe-0: a new plan on plant 2's starts as on any new
    machine (before, it took plant 1's readings for its own machine's, unbounded by the
    spread), and the prior names plant 1's machines with their database."""
    _learned(engine, "fleet-a", 0, 3)
    _learned(engine, "fleet-b", 1, 3)
    second = _second(tmp_path)
    import_tool(engine=second, data=export_tool(engine=engine, tool="CNMG432RN"), source="1.json")
    same_name = create_plan(engine=second, body=_body("here", "lathe-0"), settings=LEARN).body
    other = create_plan(engine=second, body=_body("there", "lathe-7"), settings=LEARN).body
    assert same_name["operations"] == other["operations"]
    assert same_name["provenance"] == other["provenance"]
    with Session(engine) as session:
        origin = database_id(session=session)[:8]
    machines = same_name["provenance"]["rough-od"][0]["machines"]
    assert machines == [f"lathe-0@{origin}", f"lathe-1@{origin}"]
    second.dispose()


def test_an_imported_machine_is_taken_out_and_put_back_by_its_name_here(
    engine, tmp_path, runner
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 2)
    second = _second(tmp_path)
    import_tool(engine=second, data=export_tool(engine=engine, tool="CNMG432RN"), source="1.json")
    with Session(engine) as session:
        origin = database_id(session=session)[:8]
    url = str(second.url)
    done = runner.invoke(
        app, ["fleet", "exclude", "--machine", f"lathe-0@{origin}", "--reason", "r", "--db", url]
    )
    assert done.exit_code == 0, done.output
    shown = runner.invoke(app, ["fleet", "imported", "CNMG432RN", "--db", url, "--json"])
    page = json.loads(shown.stdout)
    actor = page["machines"][0]["out"].removeprefix("taken out by ").split(":")[:2]
    assert actor[0] == "cli" and actor[1]  # the engineer's login, as every exclusion says
    assert page["machines"] == [
        {"machine": f"lathe-0@{origin}", "models": 2, "readings": 4, "in_fleet": False,
         "out": f"taken out by cli:{actor[1]}: r"},
        {"machine": f"lathe-1@{origin}", "models": 2, "readings": 4, "in_fleet": True,
         "out": ""},
    ]  # fmt: skip
    assert page["next_cursor"] is None
    # a page of one at a time, as printed: the same two, in order
    shown = runner.invoke(app, ["fleet", "imported", "CNMG432RN", "--db", url, "--limit", "1"])
    assert f"lathe-0@{origin}" in shown.output and f"lathe-1@{origin}" not in shown.output
    cursor = shown.output.split("--cursor ")[1].split()[0]
    shown = runner.invoke(
        app, ["fleet", "imported", "CNMG432RN", "--db", url, "--limit", "1", "--cursor", cursor]
    )
    assert f"lathe-1@{origin}" in shown.output and "next page" not in shown.output
    bad = runner.invoke(app, ["fleet", "imported", "CNMG432RN", "--db", url, "--cursor", "x!"])
    assert bad.exit_code == 2 and "--cursor = 'x!'" in bad.output
    shown = runner.invoke(app, ["fleet", "show", "CNMG432RN", "--db", url])
    assert f"their machines: rcb fleet imported CNMG432RN --db {url}" in " ".join(
        shown.output.split()
    )
    made = create_plan(engine=second, body=_body("c1", "lathe-9"), settings=LEARN).body
    assert made["provenance"]["rough-od"][0]["machines"] == [f"lathe-1@{origin}"]
    assert {i["machine"] for i in export_tool(engine=second, tool="CNMG432RN")["learned"]} == {
        "lathe-1"
    }  # what is out here is not sent on
    for wrong in (f"lathe-7@{origin}", "lathe-0@00000000", "lathe-0", "@"):
        done = runner.invoke(
            app, ["fleet", "exclude", "--machine", wrong, "--reason", "r", "--db", url]
        )
        assert done.exit_code == 2 and "no stored plan or imported model" in done.output
    runner.invoke(app, ["fleet", "include", "--machine", f"lathe-0@{origin}", "--db", url])
    made = create_plan(engine=second, body=_body("c2", "lathe-9"), settings=LEARN).body
    assert made["provenance"]["rough-od"][0]["machines"] == [
        f"lathe-0@{origin}",
        f"lathe-1@{origin}",
    ]
    second.dispose()
