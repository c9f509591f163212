"""A setpoint version's cycle time is summed in plan order, whatever order the rows come in.

Found by tests/api/test_two_instances.py through PgBouncer: PostgreSQL returned a version's
setpoint rows in another order than SQLite, and the floating sum of their times differed in
the last bit (1.6022585817875192 against ...195), so the same history read differently on the
two databases. 0.1 + 0.2 + 0.3 is 0.6000000000000001 in that order and 0.6 in the reverse.
"""

from __future__ import annotations

from datetime import UTC, datetime
from types import SimpleNamespace

from api.services.read import history, record

TIMES = (0.1, 0.2, 0.3)  # plan order


def _rows():
    ops = [(SimpleNamespace(id=i, name=f"op{i}"), SimpleNamespace(name="T")) for i in range(3)]
    setpoints = [
        SimpleNamespace(operation_id=i, parameters={}, predicted={}, mrr_cm3_min=1.0,
                        time_min=TIMES[i], binding=[], extras=None)
        for i in range(3)
    ]  # fmt: skip
    made = datetime.now(UTC)
    version = SimpleNamespace(version=1, cause="initial", part_id=None, created_at=made)
    return version, ops, setpoints


def test_the_sum_is_in_plan_order_for_the_history_and_the_record():
    assert sum(TIMES) != sum(reversed(TIMES))  # the premise: the order shows in the last bit
    version, ops, setpoints = _rows()
    for rows in (setpoints, setpoints[::-1]):
        shown = history._history_version(version, None, rows, ops, {}, None)
        assert shown["cycle_time_min"] == sum(TIMES) == 0.6000000000000001
        assert [op["name"] for op in shown["operations"]] == ["op0", "op1", "op2"]
        assert record._version(version, None, rows, ops)["cycle_time_min"] == sum(TIMES)
