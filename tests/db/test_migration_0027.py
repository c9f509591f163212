"""Migration 0027: each stored operation gets its plan's machine, and the indexes the fleet of
a tool is walked by (a machine's newest plans, a page of its plans by id) replace 0014's
``ix_operations_tool``; a band state's JSON ``null`` belief becomes SQL NULL, a belief stays;
the downgrade restores the index and drops the column."""

from __future__ import annotations

from sqlalchemy import inspect, text
from test_migration_0012 import _downgrade
from test_migrations import _no_difference

from db.engine import make_engine, upgrade
from db.tables import utcnow

#: Plans as 0026 stored them: name, machine, and their operations' names.
PLANS = (("p1", "lathe-a", ("rough", "finish")), ("p2", "lathe-b", ("rough",)))


def _store(url: str) -> None:
    engine = make_engine(url)
    now = {"now": utcnow()}
    with engine.begin() as c:
        for machine in ("lathe-a", "lathe-b"):
            c.execute(
                text("INSERT INTO machines (name, limits, created_at) VALUES (:m, '{}', :now)"),
                {"m": machine, **now},
            )
        c.execute(
            text(
                "INSERT INTO tools (name, process, description, material, source, created_at)"
                " VALUES ('T1', 'turning', '', '', '', :now)"
            ),
            now,
        )
        for name, machine, operations in PLANS:
            c.execute(
                text(
                    "INSERT INTO plans (name, machine_id, body, current_setpoint_version,"
                    " state_token, fleet_changes_accepted, created_at) VALUES (:name,"
                    " (SELECT id FROM machines WHERE name = :m), '{}', 1, '', 0, :now)"
                ),
                {"name": name, "m": machine, **now},
            )
            for position, op in enumerate(operations):
                c.execute(
                    text(
                        "INSERT INTO operations (plan_id, position, name, process, tool_id,"
                        " volume_mm3, limits, bounds, context) VALUES ((SELECT id FROM plans"
                        " WHERE name = :plan), :pos, :op, 'turning', (SELECT id FROM tools),"
                        " 1000, '{}', '{}', '{}')"
                    ),
                    {"plan": name, "pos": position, "op": op},
                )
        c.execute(
            text(
                "INSERT INTO parts (plan_id, serial, setpoint_version, received_at)"
                " VALUES (1, 'SN-1', 1, :now)"
            ),
            now,
        )
        for quantity, posterior in (("force_N", "null"), ("roughness_um", '{"mean": [1.0]}')):
            c.execute(
                text(
                    "INSERT INTO band_states (operation_id, quantity, part_id, seen, sigma,"
                    " posterior, wear, monitor) VALUES (1, :q, 1, 0, 0, :p, 'null', NULL)"
                ),
                {"q": quantity, "p": posterior},
            )
    engine.dispose()


def _indexes(url: str) -> set[str]:
    engine = make_engine(url)
    found = {str(ix["name"]) for ix in inspect(engine).get_indexes("operations")}
    engine.dispose()
    return found


def test_0027_gives_each_operation_its_plans_machine(backend_url):
    upgrade(backend_url, "0026")
    _store(backend_url)
    upgrade(backend_url)
    engine = make_engine(backend_url)
    with engine.connect() as c:
        found = c.execute(
            text(
                "SELECT plans.name, operations.name, machines.name FROM operations"
                " JOIN plans ON plans.id = operations.plan_id"
                " JOIN machines ON machines.id = operations.machine_id ORDER BY operations.id"
            )
        ).all()
        beliefs = c.execute(
            text(
                "SELECT quantity, posterior IS NULL, wear IS NULL, monitor IS NULL"
                " FROM band_states ORDER BY id"
            )
        ).all()
    engine.dispose()
    assert [tuple(row) for row in found] == [
        (name, op, machine) for name, machine, ops in PLANS for op in ops
    ]
    assert [tuple(row) for row in beliefs] == [
        ("force_N", True, True, True),
        ("roughness_um", False, True, True),
    ]
    assert {"ix_operations_tool_plan", "ix_operations_tool_machine_plan"} <= _indexes(backend_url)
    assert "ix_operations_tool" not in _indexes(backend_url)
    _no_difference(backend_url)
    _downgrade(backend_url, "0026")
    engine = make_engine(backend_url)
    with engine.connect() as c:
        columns = c.execute(text("SELECT * FROM operations")).keys()
    engine.dispose()
    assert "machine_id" not in columns
    assert "ix_operations_tool" in _indexes(backend_url)
