"""A database copied to set up a second site (issue 32; ``rcb models identity``, alembic 0021).

A copy holds the original's identity. Before, every model the copy learned after the copy was
skipped by the original as its own (and the original's new plans by the copy): evidence lost
without a word. Now an import skips only the models whose plan it holds under their origin,
says when a document carries its identity and plans it does not hold, and ``--renew`` gives
the copy an identity of its own while the plans it was copied with keep the original's, so a
third database that imports from both counts them once.
"""

from __future__ import annotations

import json
import shutil
import uuid
from collections.abc import Iterator

import pytest
from sqlalchemy import func, select, text
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.orm import Session
from test_fleet_db import _learned
from test_fleet_import_once import _second

from api.cli.main import app
from api.services.fleet_models import export_tool, identity, import_tool
from db import tables as t
from db.engine import make_engine

from conftest import postgres_url
from migrated import admin_engine

TOOL = "CNMG432RN"


def _server_admin() -> Engine:
    """An admin engine on the tests' PostgreSQL server (not on the database to copy)."""
    server = postgres_url()
    assert server, "a PostgreSQL backend_url is made on postgres_url()'s server"
    return admin_engine(server)


@pytest.fixture
def copy_of(backend_url) -> Iterator:  # type: ignore[no-untyped-def,type-arg]
    """``copy_of(engine)``: the test's database reopened and a copy of it (a second site's).

    ``engine`` is disposed first (a template copy needs its source idle); its pool is then
    another, which :mod:`db.bulk` does not know: the first site is the new engine returned.
    """
    made: list[tuple[str, Engine]] = []

    def copy(engine: Engine) -> tuple[Engine, Engine]:
        engine.dispose()
        url = make_url(backend_url)
        if url.get_backend_name() == "sqlite":
            target = url.set(database=f"{url.database}.copy.db")
            shutil.copyfile(str(url.database), str(target.database))
        else:  # a template copy, as createdb --template does
            target = url.set(database=f"rcb_copy_{uuid.uuid4().hex[:12]}")
            admin = _server_admin()
            with admin.connect() as c:
                c.execute(text(f'CREATE DATABASE "{target.database}" TEMPLATE "{url.database}"'))
            admin.dispose()
        made.append((str(url.database), make_engine(url)))
        made.append((target.database or "", make_engine(target)))
        return made[-2][1], made[-1][1]

    yield copy
    for _, engine in made[::2]:
        engine.dispose()
    for name, engine in made[1::2]:  # the copies
        engine.dispose()
        if engine.url.get_backend_name() != "sqlite":
            admin = _server_admin()
            with admin.connect() as c:
                c.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
            admin.dispose()


def _rows(engine: Engine) -> int:
    with Session(engine) as session:
        return int(session.scalar(select(func.count()).select_from(t.ImportedModel)) or 0)


def _origins(document: dict) -> dict[str, set[str]]:  # type: ignore[type-arg]
    found: dict[str, set[str]] = {}
    for item in document["learned"]:
        found.setdefault(item["plan"], set()).add(item["origin"])
    return found


def test_a_copy_that_kept_its_identity_still_trades_its_new_plans(
    engine, copy_of, tmp_path, runner
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    engine, second = copy_of(engine)
    _learned(second, "fleet-b", 1, 2)  # the copy's own plan, after the copy
    _learned(engine, "fleet-c", 2, 2)  # the original's, after the copy
    assert identity(engine=engine)["identity"] == identity(engine=second)["identity"]
    path = tmp_path / "second.json"
    path.write_text(json.dumps(export_tool(engine=second, tool=TOOL)))
    told = runner.invoke(app, ["models", "import", str(path), "--db", str(engine.url)])
    assert told.exit_code == 0, told.output
    said = " ".join(told.output.split())
    assert max(len(line) for line in told.output.splitlines()) <= 80  # a terminal's width
    assert "2 learned models stored from second.json (2 new; 2 learned by plans this" in said
    assert "2 of them carry this database's identity but plans it does not hold:" in said
    assert "one of second.json's database and this one is a copy of the other" in said
    assert "rcb models identity --renew" in said
    assert _rows(engine) == 2  # fleet-b's 2 quantities; fleet-a is held here
    back = import_tool(engine=second, data=export_tool(engine=engine, tool=TOOL), source="1")
    assert (back.body["new"], back.body["own"], back.body["copied"]) == (2, 4, 2)  # fleet-c


def test_a_renewed_copy_keeps_the_plans_it_was_copied_with_as_the_originals(
    engine, copy_of, tmp_path, runner
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    first_id = identity(engine=engine)["identity"]
    engine, second = copy_of(engine)
    told = runner.invoke(app, ["models", "identity", "--renew", "--db", str(second.url)])
    assert told.exit_code == 0, told.output
    second_id = identity(engine=second)["identity"]
    assert second_id != first_id and uuid.UUID(second_id)
    assert f"identity is now {second_id}" in told.output
    assert f"(was {first_id}, which its 1 plans keep)" in told.output
    assert identity(engine=second)["inherited"] == {first_id: 1}
    shown = runner.invoke(app, ["models", "identity", "--db", str(second.url)])
    assert f"1 of its plans were created under {first_id}" in shown.output
    _learned(second, "fleet-b", 1, 2)
    exported = export_tool(engine=second, tool=TOOL)
    assert _origins(exported) == {"fleet-a": {first_id}, "fleet-b": {second_id}}
    third = _second(tmp_path, "third")  # imports from both sites: fleet-a once
    import_tool(engine=third, data=export_tool(engine=engine, tool=TOOL), source="1")
    done = import_tool(engine=third, data=exported, source="2").body
    assert (done["new"], done["kept"], done["copied"]) == (2, 2, 0)
    assert _rows(third) == 4
    done = import_tool(engine=engine, data=exported, source="2").body  # back at the first site
    assert (done["new"], done["own"], done["copied"]) == (2, 2, 0)
    again = runner.invoke(app, ["models", "identity", "--renew", "--json", "--db", str(second.url)])
    assert json.loads(again.stdout)["plans_keeping_it"] == 1  # fleet-b
    assert identity(engine=second)["inherited"] == {first_id: 1, second_id: 1}
    third.dispose()
