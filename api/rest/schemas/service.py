"""The service's own bodies: an error (RFC 9457 problem details) and liveness."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, Field

from api.rest.schemas.common import Out
from api.rest.schemas.halts import HaltedOperationOut


class FieldError(BaseModel):
    """One reason a request was refused: the field, what is wrong, the value sent."""

    field: str = Field(description="the offending field, as a dotted path")
    message: str
    value: Any = Field(None, description="the offending value (at most 200 characters)")


class Problem(BaseModel):
    """RFC 9457 problem details, with the offending field."""

    type: str
    title: str
    status: int
    detail: str
    instance: str | None = None
    code: str = Field(description="machine-readable error code")
    field: str | None = Field(None, description="the offending field, as a dotted path")
    value: Any = Field(None, description="the offending value")
    errors: list[FieldError] | None = Field(
        None, description="invalid: every field refused (at most 20), the first is ``field``"
    )
    conflicts: list[HaltedOperationOut] | None = Field(
        None,
        description="infeasible and plan_halted: per operation, the limits that cannot all be "
        "met and what each would have to be (as rcb optimize --json and a halted plan give "
        "them); plan_halted on a reading past its limit by more than halt_over: no conflicts, "
        "and the message names the reading",
    )
    plan_id: int | None = Field(
        None, description="plan_name_taken: the id of the stored plan that has the name"
    )
    part_id: int | None = Field(
        None, description="conflict on serial: the id of the part already reported under it"
    )
    received_at: datetime | None = Field(
        None, description="conflict on serial: when that part was received (UTC)"
    )


class Health(Out):
    """Liveness."""

    status: Literal["ok"]


class Ready(Out):
    """Readiness: the database takes writes now."""

    status: Literal["ready"]
