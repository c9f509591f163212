"""What the MES calls: the setpoints in force, a part report, the parts a page at a time."""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from typing import Annotated, Any

from fastapi import Query, Request
from fastapi.responses import Response

from api.rest.answers import problems_at
from api.rest.deps import Anyone, EngineDep, Reporter
from api.rest.routes.common import (
    LOCATION,
    PREFIX,
    REPLAYED,
    PartId,
    PlanId,
    RequiredKey,
    answer,
    idempotency_of,
    resource_router,
)
from api.rest.schemas.common import PageOrder, PartCursor
from api.rest.schemas.parts import PartCreated, PartOut, PartReportIn, PartsPage
from api.rest.schemas.setpoints import Setpoints
from api.services import parts as use_cases
from api.services.read import plan_parts as read_parts
from api.services.read import setpoints as read_setpoints
from api.services.read.common import MAX_PAGE
from api.services.since import LONGEST_TEXT, since_of

router = resource_router("mes")


@router.get(
    "/plans/{plan_id}/setpoints",
    response_model=Setpoints,
    operation_id="getSetpoints",
    responses=problems_at(409),  # plan_halted: conflicts say why
)
def setpoints(engine: EngineDep, plan_id: PlanId, actor: Anyone) -> dict[str, Any]:
    """The setpoints in force: what the next part is made with."""
    # a key scoped to plans sees no other plan's name in the fleet's provenance
    return read_setpoints.current_setpoints(
        engine=engine, plan_id=plan_id, names=actor.plans is None
    )


@router.post(
    "/plans/{plan_id}/parts",
    status_code=201,
    response_model=PartCreated,
    operation_id="reportPart",
    responses={201: {"headers": {**REPLAYED, **LOCATION}}, **problems_at(500)},  # 500: solver
)
def report_part(
    request: Request,
    engine: EngineDep,
    plan_id: PlanId,
    report: PartReportIn,
    held: Reporter,
    idempotency_key: RequiredKey,
) -> Response:
    """Report a made part; RCB applies at the setpoint version it was made with."""
    body = report.model_dump(mode="json", exclude_none=True)
    try:
        written = use_cases.report_part(
            engine=engine,
            plan_id=plan_id,
            report=report.to_report(),
            actor=held.actor,
            idempotency=idempotency_of(request, idempotency_key, body),
            held=held,
        )
    finally:
        held.close()  # here, in the route's thread (api.rest.deps.holding)
    return answer(written, f"{PREFIX}/plans/{plan_id}/parts/{written.body.get('part_id')}")


@router.get("/plans/{plan_id}/parts/{part_id}", response_model=PartOut, operation_id="getPart")
def part(engine: EngineDep, plan_id: PlanId, part_id: PartId, actor: Anyone) -> dict[str, Any]:
    """One part as the parts' pages list it: its measurements and the RCB decisions made.

    Where a part report's 201 says it is (``Location``); a part of another plan is not found.
    """
    return read_parts.part(engine=engine, plan_id=plan_id, part_id=part_id)


@router.get("/plans/{plan_id}/parts", response_model=PartsPage, operation_id="listParts")
def parts(
    engine: EngineDep,
    plan_id: PlanId,
    actor: Anyone,
    cursor: PartCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = 50,
    order: Annotated[
        PageOrder,
        Query(description="`oldest`: pages forward from the first part; `newest`: back from now"),
    ] = "oldest",
    since: Annotated[
        str | None,
        Query(
            max_length=LONGEST_TEXT,
            description="Only the parts from the first one received at or after this ISO 8601 "
            "date or time (UTC without an offset), e.g. `2026-12-01T06:00:00Z`; send it again "
            "with each `cursor` (`rcb parts --since`)",
        ),
    ] = None,
) -> dict[str, Any]:
    """The plan's parts with their measurements and decisions, a page at a time.

    Each page lists its parts oldest first; ``next_cursor`` continues in ``order`` (a cursor
    of the other order is refused, naming the order it continues). ``since``: the parts
    received from then on (an index seek, ``ix_parts_plan_received``).
    """
    newest, after = order == "newest", since_of(since, field="since", ages=False)
    return read_parts.parts(
        engine=engine, plan_id=plan_id, cursor=cursor, page_size=limit, newest=newest, since=after
    )
