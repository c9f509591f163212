"""Tools: the packaged catalogue and the stored tools; engineers add new ones."""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from typing import Annotated, Any
from urllib.parse import quote

from fastapi import Body, Query, Request
from fastapi.responses import Response

from api.rest.answers import problems_at
from api.rest.deps import Anyone, EngineDep, Engineer
from api.rest.routes.common import (
    LOCATION,
    PREFIX,
    REPLAYED,
    OptionalKey,
    ToolName,
    answer,
    idempotency_of,
    resource_router,
)
from api.rest.schemas.common import PageOrder, PartCursor
from api.rest.schemas.tools import (
    FleetLawOut,
    FleetList,
    ImportedFleetList,
    TextCursor,
    ToolList,
    ToolOut,
)
from api.services import tools as use_cases
from api.services.read import tools as read_tools
from api.services.read.common import LIST_PAGE, MAX_PAGE
from api.services.read.fleet import fleet_law, fleet_members, imported_fleet
from models.tool import tool_body

router = resource_router("tools")


@router.get("/tools", response_model=ToolList, operation_id="listTools")
def list_tools(
    engine: EngineDep,
    actor: Anyone,
    cursor: TextCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = LIST_PAGE,
) -> dict[str, Any]:
    """The packaged catalogue and the tools added by engineers, by name, a page at a time."""
    return read_tools.list_tools(engine=engine, cursor=cursor, page_size=limit)


@router.get("/tools/{name}", response_model=ToolOut, operation_id="getTool")
def get_tool(
    engine: EngineDep,
    name: ToolName,
    actor: Anyone,
) -> dict[str, Any]:
    """One tool with its baseline models and their provenance."""
    return read_tools.get_tool(engine=engine, name=name)


@router.get("/tools/{name}/fleet", response_model=FleetList, operation_id="getToolFleet")
def get_tool_fleet(
    engine: EngineDep,
    name: ToolName,
    actor: Anyone,
    cursor: PartCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = LIST_PAGE,
    order: Annotated[
        PageOrder,
        Query(
            description="`oldest`: by id from the first plan; `newest`: back from the newest, "
            "each machine's newest plans (those in the fleet) first"
        ),
    ] = "oldest",
) -> dict[str, Any]:
    """The stored plans using the tool, by id: each in the fleet or why not.

    New plans' fleet priors come from those in it. A key scoped to plans: those plans only.
    ``next_cursor`` continues in ``order`` (a cursor of the other order is refused).
    """
    return fleet_members(
        engine=engine,
        tool=name,
        cursor=cursor,
        page_size=limit,
        only=actor.plans,
        newest=order == "newest",
    )


@router.get(
    "/tools/{name}/fleet/imported",
    response_model=ImportedFleetList,
    operation_id="getToolFleetImported",
)
def get_tool_fleet_imported(
    engine: EngineDep,
    name: ToolName,
    actor: Anyone,
    cursor: TextCursor = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = LIST_PAGE,
) -> dict[str, Any]:
    """The machines of the tool's models imported from other databases, a page at a time.

    Each by the name the fleet gives it (NAME@ORIGIN), in the fleet or taken out (``rcb fleet
    exclude --machine``) and why. A key scoped to plans sees none.
    """
    return imported_fleet(
        engine=engine, tool=name, cursor=cursor, page_size=limit, only=actor.plans
    )


@router.get(
    "/tools/{name}/fleet/law",
    response_model=FleetLawOut,
    operation_id="getToolFleetLaw",
    responses=problems_at(409),  # a stored tool this version's check refuses (GET /tools)
)
def get_tool_fleet_law(
    engine: EngineDep,
    name: ToolName,
    actor: Anyone,
) -> dict[str, Any]:
    """What the fleet learned of the tool's law: K, exponents and spreads beside the catalogue.

    Per measured quantity, from the plans in the fleet, as a new plan's fleet prior starts;
    counts only, no plan's name (a key scoped to plans sees it too).
    """
    return fleet_law(engine=engine, tool=name)


@router.post(
    "/tools",
    status_code=201,
    response_model=ToolOut,
    operation_id="addTool",
    responses={201: {"headers": {**REPLAYED, **LOCATION}}},
)
def add_tool(
    request: Request,
    engine: EngineDep,
    tool: Annotated[dict[str, Any], Body()],
    actor: Engineer,
    idempotency_key: OptionalKey = None,
) -> Response:
    """Add a tool with its baseline models (a new name; stored tools never change)."""
    body = tool_body(tool)  # read by the tool reader alone (ToolIn documents it)
    body.setdefault("source", "REST API")  # the reader's default would say "plan file"
    written = use_cases.add_tool(
        engine=engine,
        body=body,
        actor=actor,
        idempotency=idempotency_of(request, idempotency_key, body),
    )
    # the name as a path segment: a tool's name may hold "/", "?", "#" or a space
    return answer(written, f"{PREFIX}/tools/{quote(str(written.body.get('name')), safe='')}")
