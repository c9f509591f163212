"""rcb_decisions stores a Decision field by field: its columns are pinned to the dataclass."""

from __future__ import annotations

import dataclasses

from db import tables as t
from db.parts import DECISION_COLUMNS
from supervisor.rcb.state import Decision

#: Decision fields that rcb_decisions does not store under their own name, and why.
NOT_STORED = {
    "operation": "stored as operation_id (the operations row of that name)",
    "predicted": "the setpoint version the part was made with holds the prediction",
    "measured": "the part's measurements row holds the value",
    "uncertainty": "the part's measurements row holds the uncertainty",
    "limit": "the operation's limits hold it (operations.limits, plan revisions)",
}
#: Columns of rcb_decisions that are not Decision fields.
KEYS = {"id", "part_id", "operation_id"}


def test_every_decision_field_has_its_column_or_a_reason():
    fields = {f.name for f in dataclasses.fields(Decision)}
    columns = {c.key for c in t.core_table(t.RcbDecision).columns}
    missing = fields - columns - set(NOT_STORED)
    assert not missing, f"Decision fields with no rcb_decisions column: {sorted(missing)}"
    assert not set(NOT_STORED) & columns, "a field said not to be stored has a column"
    assert set(NOT_STORED) <= fields, "NOT_STORED names a field Decision no longer has"
    assert columns - KEYS <= fields, (
        f"columns that are no Decision field: {columns - KEYS - fields}"
    )


def test_the_rows_a_part_writes_carry_exactly_the_stored_fields():
    fields = {f.name for f in dataclasses.fields(Decision)}
    assert set(DECISION_COLUMNS) == fields - set(NOT_STORED)
    assert len(DECISION_COLUMNS) == len(set(DECISION_COLUMNS))
