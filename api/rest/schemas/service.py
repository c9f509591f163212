"""The service's own bodies: an error (RFC 9457 problem details) and liveness."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field

from api.rest.schemas.common import Out


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
    errors: list[dict[str, Any]] | None = None
    conflicts: list[dict[str, Any]] | None = Field(
        None,
        description="plan_halted: per operation, the limits that cannot be met (none, and "
        "the message naming the reading, for a reading past its limit by more than halt_over)",
    )
    plan_id: int | None = Field(
        None, description="plan_name_taken: the id of the stored plan that has the name"
    )


class Health(Out):
    """Liveness."""

    status: Literal["ok"]
