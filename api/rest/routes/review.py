"""What engineers review: every setpoint version, the models in force and their versions."""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from typing import Annotated, Any

from fastapi import Query
from fastapi.responses import Response

from api.rest.deps import Anyone, EngineDep
from api.rest.rendering import page_response
from api.rest.routes.common import Named, PlanId, resource_router
from api.rest.schemas.common import NO_NUL, PageOrder, PartCursor
from api.rest.schemas.review import History, ModelVersions, PlanModels
from api.rest.schemas.tools import TextCursor
from api.services.read import history as read_history
from api.services.read import plan_models as read_models
from api.services.read.common import LIST_PAGE, MAX_PAGE
from api.services.writes_first import GATE
from models.bounds import MAX_IDENTITY

router = resource_router("review")


@router.get("/plans/{plan_id}/history", response_model=History, operation_id="getHistory")
def plan_history(
    engine: EngineDep,
    plan_id: PlanId,
    actor: Anyone,
    cursor: PartCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = read_history.HISTORY_PAGE,
    order: Annotated[
        PageOrder,
        Query(description="`oldest`: pages forward from version 1; `newest`: back from now"),
    ] = "oldest",
) -> Response:
    """Setpoint versions with their cause and the bands in force, a page at a time.

    Each page lists its versions oldest first; ``next_cursor`` continues in ``order``.
    """
    with GATE.reading():  # one long read at a time, part reports first (api.services.writes_first)
        data = read_history.plan_history(
            engine=engine,
            plan_id=plan_id,
            cursor=cursor,
            page_size=limit,
            newest=order == "newest",
        )
        return page_response(History, data, "versions")


@router.get("/plans/{plan_id}/models", response_model=PlanModels, operation_id="getModels")
def plan_models(engine: EngineDep, plan_id: PlanId, actor: Anyone) -> dict[str, Any]:
    """Per operation and quantity the model in force."""
    return read_models.models_in_force(engine=engine, plan_id=plan_id)


@router.get(
    "/plans/{plan_id}/models/versions",
    response_model=ModelVersions,
    operation_id="listModelVersions",
)
def model_versions(
    engine: EngineDep,
    plan_id: PlanId,
    actor: Anyone,
    operation: Annotated[str | None, Query(max_length=MAX_IDENTITY, pattern=NO_NUL), Named] = None,
    quantity: Annotated[str | None, Query(max_length=50, pattern=NO_NUL), Named] = None,
    cursor: TextCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = LIST_PAGE,
) -> dict[str, Any]:
    """Model versions with their cause, optionally of one operation and quantity, by page.

    By version, then operation (plan order), then quantity.
    """
    return read_models.model_versions(
        engine=engine,
        plan_id=plan_id,
        operation=operation,
        quantity=quantity,
        cursor=cursor,
        page_size=limit,
    )
