"""Plans: create (check and optimise), replan, list, read one."""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from typing import Annotated, Any, Literal

from fastapi import Body, Depends, Query, Request
from fastapi.responses import Response

from api.rest.answers import problems_at
from api.rest.deps import Anyone, EngineDep, Engineer
from api.rest.routes.common import (
    LOCATION,
    PREFIX,
    REPLAYED,
    OptionalKey,
    PlanId,
    answer,
    idempotency_of,
    resource_router,
)
from api.rest.schemas.common import IdCursor
from api.rest.schemas.plans import PLAN_EXAMPLE, PlanCreated, PlanDetail, PlanList
from api.rest.schemas.rcb_settings import settings_in_query
from api.rest.schemas.replan import ReplanIn, Replanned
from api.services import plans as use_cases
from api.services.read import plans as read_plans
from api.services.read.common import LIST_PAGE, MAX_PAGE
from models.errors import InputError
from supervisor.inputs.plan import plan_body
from supervisor.rcb.replan import replan_body

router = resource_router("plans")


@router.post(
    "/plans",
    status_code=201,
    response_model=PlanCreated,
    operation_id="createPlan",
    responses={201: {"headers": {**REPLAYED, **LOCATION}}, **problems_at(500)},  # 500: solver
)
def create_plan(
    request: Request,
    engine: EngineDep,
    plan: Annotated[dict[str, Any], Body(openapi_examples=PLAN_EXAMPLE)],
    actor: Engineer,
    given: Annotated[dict[str, object], Depends(settings_in_query)],
    idempotency_key: OptionalKey = None,
    prior: Annotated[
        Literal["fleet", "catalogue"] | None,
        Query(
            description="learn's start: fleet (what the stored plans learned with the plan's "
            "tools) or catalogue; default: fleet where the database holds evidence for them"
        ),
    ] = None,
) -> Response:
    """Check and optimise a plan (the plan-file structure as JSON); setpoint version 1."""
    # read by the plan reader alone (PlanIn documents it: api.rest.documented)
    body = plan_body(plan)
    written = use_cases.create_plan(
        engine=engine,
        body=body,
        given=given,  # over the plan's rcb table; its errors and the plan's together
        actor=actor,
        idempotency=idempotency_of(request, idempotency_key, {**body, "?prior": prior}),
        prior=prior,
    )
    return answer(written, f"{PREFIX}/plans/{written.body.get('id')}")


@router.post(
    "/plans/{plan_id}/replan",
    status_code=201,
    response_model=Replanned,
    operation_id="replanPlan",
    responses={
        200: {"model": Replanned, "description": "dry run: nothing stored"},
        201: {"headers": REPLAYED},
        **problems_at(500),  # the solver failed
    },
)
def replan(
    request: Request,
    engine: EngineDep,
    plan_id: PlanId,
    changes: Annotated[dict[str, Any], Body()],
    actor: Engineer,
    dry_run: Annotated[bool, Query(description="show the result, store nothing")] = False,
    idempotency_key: OptionalKey = None,
) -> Response:
    """Change limits, bounds or models (or reset the bands) and re-optimise.

    ``reason`` (why, kept in the audit entry) is no change: the use case checks it apart.
    """
    body = replan_body(changes)  # read by the replan alone (ReplanIn documents it)
    only = {k: v for k, v in body.items() if k != "reason"}
    try:
        written = use_cases.replan(
            engine=engine,
            plan_id=plan_id,
            changes=only,
            dry_run=dry_run,
            actor=actor,
            idempotency=None if dry_run else idempotency_of(request, idempotency_key, body),
            reason=body.get("reason"),
        )
    except InputError as err:
        if err.field != "changes":  # the reader's name of the whole of them: the body here
            raise
        given = ", ".join(k for k in ReplanIn.model_fields if k != "reason")
        raise InputError("body", body, f"{err.reason}: give one of {given}") from None
    return answer(written)


@router.get("/plans", response_model=PlanList, operation_id="listPlans")
def list_plans(
    engine: EngineDep,
    actor: Anyone,
    cursor: IdCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = LIST_PAGE,
) -> dict[str, Any]:
    """The plans by id, a page at a time (a key scoped to plans: those plans only)."""
    return read_plans.list_plans(engine=engine, cursor=cursor, page_size=limit, only=actor.plans)


@router.get("/plans/{plan_id}", response_model=PlanDetail, operation_id="getPlan")
def get_plan(engine: EngineDep, plan_id: PlanId, actor: Anyone) -> dict[str, Any]:
    """One plan: machine limits, operations, and the structure it was created from."""
    # a key scoped to plans sees no other plan's name in the fleet's provenance
    return read_plans.get_plan(engine=engine, plan_id=plan_id, names=actor.plans is None)
