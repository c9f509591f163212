"""db.bulk stores exactly what executemany stores, on PostgreSQL and SQLite, in one statement."""

from __future__ import annotations

import json
import math
import tomllib
from datetime import UTC, datetime

import pytest
from sqlalchemy import (
    JSON,
    Boolean,
    Column,
    DateTime,
    Float,
    Integer,
    MetaData,
    String,
    Table,
    Text,
    event,
    insert,
    select,
    text,
)
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services.idempotency import Idempotency
from api.services.keys import create_key
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.api_keys import Actor
from db.bulk import Encoded, defer, write_rows
from db.engine import make_engine, upgrade

from conftest import DEMO_PLAN


def _tables() -> tuple[MetaData, Table, Table, Table]:
    metadata = MetaData()
    columns = lambda: [  # noqa: E731
        Column("id", Integer, primary_key=True),
        Column("part_id", Integer),
        Column("quantity", String(50)),
        Column("value", Float),
        Column("margin", Float, nullable=True),
        Column("flagged", Boolean),
        Column("reason", Text),
        Column("raw", JSON, nullable=True),
        Column("created_at", DateTime(timezone=True)),
    ]
    return (
        metadata,
        Table("bulk_reference", metadata, *columns()),
        Table("bulk_a", metadata, *columns()),
        Table("bulk_b", metadata, Column("id", Integer, primary_key=True), Column("dK", Float)),
    )


ROWS = [
    {
        "part_id": i,
        "quantity": "force_N" if i % 2 else "roughness_um",
        "value": v,
        "margin": None if i == 1 else -v / 3,
        "flagged": bool(i % 2),
        "reason": 'it\'s "quoted" and ünïcode',
        "raw": None if i % 3 == 0 else {"volume_mm3": 1.5e-300 * i, "note": "x", "list": [1, 2]},
        "created_at": datetime(2026, 11, 22, 7, 49, 37, 123456, tzinfo=UTC),
    }
    for i, v in enumerate([0.1, 1 / 3, 1867.0000000000002, 5e-324, 1.7976931348623157e308])
]


@pytest.fixture(params=["sqlite", "postgres"])
def engine(request, tmp_path):
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path / 'bulk.db'}"
    else:
        url = request.getfixturevalue("empty_postgres")
    engine = make_engine(url)
    yield engine
    engine.dispose()


def _stored(connection, table):
    raw = "CAST(raw AS TEXT)" if connection.dialect.name == "postgresql" else "raw"
    rows = connection.execute(select(table).order_by(table.c.id)).mappings().all()
    texts = connection.execute(text(f"SELECT {raw} FROM {table.name} ORDER BY id")).scalars()
    return [{k: v for k, v in row.items() if k != "id"} for row in rows], list(texts)


def test_rows_of_several_tables_are_stored_as_executemany_stores_them(engine):
    metadata, reference, a, b = _tables()
    metadata.create_all(engine)
    with engine.begin() as connection:
        connection.execute(insert(reference), ROWS)
        sent: list[str] = []
        event.listen(connection, "before_cursor_execute", lambda *args: sent.append(args[2]))
        write_rows(connection, [(a, ROWS), (b, [{"dK": 0.25}, {"dK": 7.0}]), (reference, [])])
        if engine.dialect.name == "postgresql":  # both tables in one statement
            assert len(sent) == 1 and sent[0].count("json_to_recordset") == 2
        expected, expected_text = _stored(connection, reference)
        got, got_text = _stored(connection, a)
        assert got == expected  # floats bit for bit, NULL margin, booleans, the time
        assert got_text == expected_text  # a None in a JSON column is JSON null, as SQLAlchemy
        assert [r.dK for r in connection.execute(select(b).order_by(b.c.id))] == [0.25, 7.0]


def test_an_encoded_json_value_is_stored_as_its_value_is(engine):
    """A value given with its JSON text (db.bulk.Encoded) is stored as the plain value is,
    in the one statement (PostgreSQL) and through executemany (SQLite, or a NaN elsewhere)."""
    metadata, reference, a, _ = _tables()
    metadata.create_all(engine)
    tricky = {"answer": [1 / 3, 5e-324, None, 'ünï "quoted" x:0'], "nested": {"k": True}}
    rows = [dict(row, raw=Encoded.of(row["raw"])) for row in ROWS]
    rows[1] = dict(rows[1], raw=Encoded.of(tricky))
    plain = [dict(row, raw=tricky if i == 1 else row["raw"]) for i, row in enumerate(ROWS)]
    with engine.begin() as connection:
        connection.execute(insert(reference), plain)
        sent: list[str] = []
        event.listen(connection, "before_cursor_execute", lambda *args: sent.append(args[2]))
        write_rows(connection, [(a, rows)])
        if engine.dialect.name == "postgresql":
            assert len(sent) == 1 and "json_to_recordset" in sent[0]
        write_rows(connection, [(a, [dict(rows[1], value=math.nan)])])  # executemany
        expected, expected_text = _stored(connection, reference)
        got, got_text = _stored(connection, a)
        assert got[:-1] == expected and got_text[:-1] == expected_text
        assert got[-1]["raw"] == tricky and got_text[-1] == expected_text[1]
    assert Encoded.of(tricky).text == json.dumps(tricky)  # what SQLAlchemy's JSON type stores
    with pytest.raises(ValueError):
        Encoded.of({"x": math.inf})


def test_rows_json_cannot_carry_exactly_fall_back_to_executemany(engine):
    metadata, reference, a, _ = _tables()
    metadata.create_all(engine)
    odd = [dict(ROWS[0], value=math.inf), dict(ROWS[1], margin=math.nan)]
    partial = [{k: v for k, v in ROWS[2].items() if k != "reason"}]  # reason left to its default
    with engine.begin() as connection:
        connection.execute(insert(reference), odd)
        connection.execute(insert(reference), partial)
        write_rows(connection, [(a, odd)])
        write_rows(connection, [(a, partial)])
        expected, got = _stored(connection, reference)[0], _stored(connection, a)[0]
        assert repr(got) == repr(expected)  # nan (None on SQLite) and inf as executemany's
        assert got[0]["value"] == math.inf and got[2]["reason"] is None


def test_updates_by_primary_key_are_applied_as_executemany_applies_them(engine):
    metadata, reference, a, _ = _tables()
    metadata.create_all(engine)
    changes = [
        {"id": 2, "value": 1 / 7, "raw": None, "reason": "ünï"},
        {"id": 4, "value": 5e-324, "raw": {"n": [1.5e-300]}, "reason": "x"},
    ]
    with engine.begin() as connection:
        connection.execute(insert(reference), ROWS)
        connection.execute(insert(a), ROWS)
        sent: list[str] = []
        event.listen(connection, "before_cursor_execute", lambda *args: sent.append(args[2]))
        write_rows(connection, [], updates=[(a, changes)])
        if engine.dialect.name == "postgresql":  # one statement for both rows
            assert len(sent) == 1 and sent[0].startswith("UPDATE")
        for change in changes:  # the reference: one UPDATE per row
            values = {k: v for k, v in change.items() if k != "id"}
            connection.execute(
                reference.update().where(reference.c.id == change["id"]).values(values)
            )
        expected, expected_text = _stored(connection, reference)
        got, got_text = _stored(connection, a)
        assert got == expected and got_text == expected_text


def test_deferred_rows_are_written_by_the_commit_or_forgotten_by_a_rollback(engine):
    metadata, _, a, b = _tables()
    metadata.create_all(engine)
    with Session(engine) as session, session.begin():
        defer(session, [(a, ROWS[:2])], updates=[])
    with pytest.raises(RuntimeError), Session(engine) as session, session.begin():
        defer(session, [(b, [{"dK": 1.0}])])
        raise RuntimeError("refused")
    with engine.connect() as connection:
        assert len(connection.execute(select(a)).all()) == 2
        assert connection.execute(select(b)).all() == []


def test_a_part_report_writes_its_rows_key_audit_and_plan_in_one_statement(engine):
    upgrade(engine.url.render_as_string(hide_password=False))
    body = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    plan = create_plan(engine=engine, body=body).body
    key = create_key(engine=engine, role="mes")
    actor = Actor(key["id"], "mes", f"key:{key['id']}")
    report = {
        "serial": "SN-1",
        "setpoint_version": 1,
        "operations": [
            {
                "name": op["name"],
                "measurements": {
                    "force_N": {
                        "value": 0.5 * op["predicted"]["force_N"]["value"],
                        "uncertainty": 3.0,
                    }
                },
            }
            for op in plan["operations"]
        ],
    }
    sent: list[str] = []
    event.listen(engine, "before_cursor_execute", lambda *args: sent.append(args[2]))
    written = report_part(
        engine=engine,
        plan_id=plan["id"],
        report=parse_report(report),
        actor=actor,
        idempotency=Idempotency("k-1", "f" * 64),
    )
    assert written.status == 201
    if engine.dialect.name == "postgresql":
        last = [s for s in sent if "json_to_recordset" in s]
        assert len(last) == 1
        for table in ("measurements", "rcb_decisions", "idempotency_records", "audit_log"):
            assert f"INSERT INTO {table} " in last[0]
        assert "UPDATE plans " in last[0]
    with Session(engine) as session:
        record = session.scalars(select(t.IdempotencyRecord)).one()
        assert record.response_body == written.body and record.response_status == 201
        audit = session.scalars(select(t.AuditEntry).where(t.AuditEntry.actor == actor.name)).one()
        assert (audit.action, audit.result, audit.detail) == ("report part", "201", None)
        row = session.get(t.Plan, plan["id"])
        assert row is not None and row.current_setpoint_version == written.body["setpoint_version"]
