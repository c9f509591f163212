"""A decision's fields are defined once, by supervisor.rcb.state.Decision (issue 16).

rcb_decisions stores it field by field, a part report's ``updates`` show it as JSON
(api.services.to_json.decision_json, the REST schema Update) and the history reads it back
(api.services.read): each is pinned here to the dataclass.
"""

from __future__ import annotations

import dataclasses

from api.rest.schemas.parts import Update
from api.services import read as queries
from api.services.to_json import decision_json
from db import tables as t
from db.parts import DECISION_COLUMNS
from supervisor.rcb.decision import Decision

#: Decision fields that rcb_decisions does not store under their own name, and why.
NOT_STORED = {
    "operation": "stored as operation_id (the operations row of that name)",
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


#: Decision fields a part report's JSON leaves out, and why.
NOT_SHOWN = {
    "uncertainty": "the part's measurement, sent by the MES, holds it",
    "limit": "the operation's limits hold it",
    "dK_before": "the model versions (GET .../models) carry the bands of K",
    "dK_after": "the model versions (GET .../models) carry the bands of K",
    "K_before": "the model versions (GET .../models) carry K",
    "K_after": "the model versions (GET .../models) carry K",
}


def _decision(**changes):
    values = {
        "operation": "rough-od",
        "quantity": "force_N",
        "action": "shrink",
        "margin": 90.0,
        "band_before": 100.0,
        "band_after": 77.5,
        "predicted": 1900.0,
        "measured": 1800.0,
        "uncertainty": 10.0,
        "dK_before": 40.0,
        "dK_after": 31.0,
        "K_before": 2280.0,
        "K_after": 2280.0,
        "limit": 2000.0,
        "flagged": False,
        "reason": "r",
    }
    return Decision(**{**values, **changes})


def test_the_json_of_a_decision_is_its_fields_and_the_rest_schema_says_the_same():
    fields = [f.name for f in dataclasses.fields(Decision)]
    shown = decision_json(_decision())
    assert set(shown) == set(fields) - set(NOT_SHOWN)
    assert set(Update.model_fields) == set(shown)
    Update.model_validate(shown)  # the answer the REST schema checks


def test_the_history_reads_back_the_stored_fields_under_the_json_names():
    row = t.RcbDecision(
        part_id=1,
        operation_id=7,
        **{c: getattr(_decision(), c) for c in DECISION_COLUMNS},
    )
    read = queries.decision_json(row, {7: "rough-od"})
    assert read == {k: v for k, v in decision_json(_decision()).items() if k not in NOT_STORED} | {
        "operation": "rough-od"
    }
