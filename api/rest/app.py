"""The REST service the MES calls between parts (FastAPI, under ``/api/v1``).

``create_app(url)`` builds the app on a database; ``app_from_env`` is the factory uvicorn
workers import (``RCB_DATABASE_URL``). Routes are thin: authentication and roles, then one call
of a use case of :mod:`api.services` (writes) or :mod:`api.services.queries` (reads).
"""

# no "from __future__ import annotations": FastAPI must see the route annotations, which use
# names local to create_app

import os
from collections.abc import AsyncIterator, Callable
from typing import Annotated, Any

from anyio import CancelScope
from fastapi import Body, Depends, FastAPI, Header, Path, Query, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse, Response
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api.report import ui
from api.rest import auth, problems, schemas
from api.rest.problems import ProblemError
from api.services import idempotency, plans, queries, tools
from api.services import parts as part_use_cases
from db.access import Actor
from db.engine import DEFAULT_URL, make_engine
from supervisor.rcb.strategies import DEFAULT_ALPHA, DEFAULT_STRATEGY
from supervisor.rcb.update import RcbSettings

PREFIX = "/api/v1"
#: Largest id (the tables' integer keys are 32-bit on PostgreSQL).
MAX_ID = 2**31 - 1
#: Idempotency-Key: 1 to 255 visible ASCII characters (an sf-string; the column's width).
KEY_PATTERN = r"^[\x21-\x7e]{1,255}$"
_KEY_DOC = (
    "a client-chosen unique key per request (IETF Idempotency-Key draft); 1-255 visible ASCII"
)

#: The defaults of the plan settings the create route takes.
_DEFAULTS = RcbSettings()
_bearer = HTTPBearer(auto_error=False, description="An API key from `rcb keys create`.")
_PROBLEMS: dict[int | str, dict[str, Any]] = {
    status: {"model": schemas.Problem, "content": {problems.MEDIA_TYPE: {}}}
    for status in (400, 401, 403, 404, 409, 422)
}


def create_app(url: str) -> FastAPI:
    """The service on the database at ``url`` (migrated beforehand: ``rcb db upgrade``)."""
    engine = make_engine(url)
    app = FastAPI(
        title="rcb-supervisor",
        version="1",
        summary="Robust cutting parameters, tightened part by part (Recursive Constraint Bounding)",
        openapi_url=f"{PREFIX}/openapi.json",
        docs_url=f"{PREFIX}/docs",
        redoc_url=None,
        responses=_PROBLEMS,
    )
    app.state.engine = engine
    problems.install(app)
    ui.install(app, engine)  # the read-only web view at /ui/ (api/report/ui.py)

    def action_of(request: Request) -> str:
        route = request.scope.get("route")
        return f"{request.method} {getattr(route, 'path', '?')}"  # the template: bounded

    def unauthorized(key: str | None) -> ProblemError:
        return ProblemError(
            401,
            "unauthorized",
            "missing API key" if key is None else "unknown or revoked API key",
            "Authorization",
            headers={"WWW-Authenticate": "Bearer"},
        )

    def allowed_actor(
        actor: Actor | None,
        key: str | None,
        action: str,
        allowed: tuple[str, ...],
        held: auth.Authenticated | None = None,
    ) -> Actor:
        if actor is None:
            raise unauthorized(key)
        if actor.role not in allowed:
            auth.audit_forbidden(engine=engine, actor=actor, action=action, held=held)
            raise ProblemError(
                403,
                "forbidden",
                f"role {actor.role!r} may not do this; allowed: {', '.join(allowed)}",
                "Authorization",
                actor.role,
            )
        return actor

    def role(*allowed: str) -> Callable[..., Actor]:
        def check(
            request: Request,
            credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
        ) -> Actor:
            action = action_of(request)
            key = credentials.credentials if credentials else None
            actor = auth.authenticate(engine=engine, key=key, action=action)
            return allowed_actor(actor, key, action, allowed)

        return check

    def holding(*allowed: str) -> Callable[..., AsyncIterator[auth.Authenticated]]:
        """As :func:`role`, keeping the key's transaction for the write (auth.authenticated).

        The key is checked in a worker thread; the route gives the connection back itself
        (in its own thread), so the usual case needs no third hop to a thread to end the
        request; a request that never reached the route is released here.
        """

        def open_checked(
            key: str | None, action: str, idempotency_key: str | None
        ) -> auth.Authenticated:
            held = auth.authenticate_write(
                engine=engine, key=key, action=action, idempotency_key=idempotency_key
            )
            if held is None:
                raise unauthorized(key)
            try:
                allowed_actor(held.actor, key, action, allowed, held)
            except BaseException:
                held.close()
                raise
            return held

        async def check(
            request: Request,
            credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
        ) -> AsyncIterator[auth.Authenticated]:
            key = credentials.credentials if credentials else None
            held = await run_in_threadpool(
                open_checked, key, action_of(request), request.headers.get("Idempotency-Key")
            )
            try:
                yield held
            finally:
                if held.session is not None:  # the route did not run (a refused body)
                    with CancelScope(shield=True):
                        await run_in_threadpool(held.close)

        return check

    anyone = Depends(role("mes", "engineer", "viewer"))
    engineer = Depends(role("engineer"))
    PlanId = Annotated[int, Path(ge=1, le=MAX_ID)]

    @app.get(f"{PREFIX}/health", response_model=schemas.Health, tags=["service"])
    def health() -> dict[str, str]:
        """Liveness; no key needed."""
        return {"status": "ok"}

    @app.post(
        f"{PREFIX}/plans",
        status_code=201,
        response_model=schemas.PlanCreated,
        tags=["plans"],
        responses={201: {"headers": _REPLAYED}},
    )
    def create_plan(
        request: Request,
        plan: Annotated[schemas.PlanIn, Body(openapi_examples=_PLAN_EXAMPLE)],
        actor: Annotated[Actor, engineer],
        strategy: Annotated[schemas.Strategy, Query(description=schemas.STRATEGY_DOC)] = (
            DEFAULT_STRATEGY
        ),
        alpha: Annotated[
            float,
            Query(gt=0, le=1, allow_inf_nan=False, description="fraction of the margin"),
        ] = DEFAULT_ALPHA,
        floor: Annotated[
            list[str] | None,
            Query(description="least band QUANTITY=VALUE (repeatable); default: the u"),
        ] = None,
        coverage_k: Annotated[
            float, Query(gt=0, le=100, allow_inf_nan=False, description="the band as k σ")
        ] = _DEFAULTS.coverage_k,
        discrepancy: Annotated[
            float | None,
            Query(ge=0, le=10, allow_inf_nan=False, description="τ; default: the strategy's"),
        ] = None,
        z: Annotated[
            float, Query(gt=0, le=100, allow_inf_nan=False, description="learn: the cone's z")
        ] = _DEFAULTS.z,
        exponent_sd: Annotated[
            float,
            Query(ge=0, le=10, allow_inf_nan=False, description="learn: exponent prior sd"),
        ] = _DEFAULTS.exponent_sd,
        edge_sd: Annotated[
            float,
            Query(ge=0, le=10, allow_inf_nan=False, description="learn: wear prior sd per edge"),
        ] = _DEFAULTS.edge_sd,
        idempotency_key: Annotated[
            str | None, Header(pattern=KEY_PATTERN, description=_KEY_DOC)
        ] = None,
    ) -> Response:
        """Check and optimise a plan (the plan-file structure as JSON); setpoint version 1."""
        body = plan.model_dump(mode="json", exclude_none=True)
        settings = RcbSettings(
            strategy=strategy,
            alpha=alpha,
            floors=plans.floors_from(floor or [], "floor"),
            coverage_k=coverage_k,
            discrepancy=discrepancy,
            z=z,
            exponent_sd=exponent_sd,
            edge_sd=edge_sd,
        )
        written = plans.create_plan(
            engine=engine,
            body=body,
            settings=settings,
            actor=actor,
            idempotency=_idempotency(request, idempotency_key, body),
        )
        return _written(written)

    @app.post(
        f"{PREFIX}/plans/{{plan_id}}/replan",
        status_code=201,
        response_model=schemas.Replanned,
        tags=["plans"],
        responses={200: {"model": schemas.Replanned, "description": "dry run: nothing stored"}},
    )
    def replan(
        request: Request,
        plan_id: PlanId,
        changes: schemas.ReplanIn,
        actor: Annotated[Actor, engineer],
        dry_run: Annotated[bool, Query(description="show the result, store nothing")] = False,
        idempotency_key: Annotated[
            str | None, Header(pattern=KEY_PATTERN, description=_KEY_DOC)
        ] = None,
    ) -> Response:
        """Change limits, bounds or models (or reset the bands) and re-optimise."""
        body = changes.model_dump(mode="json", exclude_none=True)
        written = plans.replan(
            engine=engine,
            plan_id=plan_id,
            changes=body,
            dry_run=dry_run,
            actor=actor,
            idempotency=None if dry_run else _idempotency(request, idempotency_key, body),
        )
        return _written(written)

    @app.get(f"{PREFIX}/plans", response_model=schemas.PlanList, tags=["plans"])
    def list_plans(actor: Annotated[Actor, anyone]) -> dict[str, Any]:
        """Every plan."""
        return queries.list_plans(engine=engine)

    @app.get(f"{PREFIX}/plans/{{plan_id}}", response_model=schemas.PlanDetail, tags=["plans"])
    def get_plan(plan_id: PlanId, actor: Annotated[Actor, anyone]) -> dict[str, Any]:
        """One plan: machine limits, operations, and the structure it was created from."""
        return queries.get_plan(engine=engine, plan_id=plan_id)

    @app.get(
        f"{PREFIX}/plans/{{plan_id}}/setpoints", response_model=schemas.Setpoints, tags=["mes"]
    )
    def setpoints(plan_id: PlanId, actor: Annotated[Actor, anyone]) -> dict[str, Any]:
        """The setpoints in force: what the next part is made with."""
        return queries.current_setpoints(engine=engine, plan_id=plan_id)

    @app.post(
        f"{PREFIX}/plans/{{plan_id}}/parts",
        status_code=201,
        response_model=schemas.PartCreated,
        tags=["mes"],
        responses={201: {"headers": _REPLAYED}},
    )
    def report_part(
        request: Request,
        plan_id: PlanId,
        report: schemas.PartReportIn,
        held: Annotated[auth.Authenticated, Depends(holding("mes", "engineer"))],
        idempotency_key: Annotated[str, Header(pattern=KEY_PATTERN, description=_KEY_DOC)],
    ) -> Response:
        """Report a made part; RCB applies at the setpoint version it was made with."""
        body = report.model_dump(mode="json", exclude_none=True)
        try:
            written = part_use_cases.report_part(
                engine=engine,
                plan_id=plan_id,
                body=body,
                actor=held.actor,
                idempotency=_idempotency(request, idempotency_key, body),
                held=held,
            )
        finally:
            held.close()  # here, in the route's thread (see holding)
        return _written(written)

    @app.get(f"{PREFIX}/plans/{{plan_id}}/parts", response_model=schemas.PartsPage, tags=["mes"])
    def parts(
        plan_id: PlanId,
        actor: Annotated[Actor, anyone],
        cursor: Annotated[
            str | None,
            Query(pattern=r"^[0-9]{1,10}$", description="`next_cursor` of the previous page"),
        ] = None,
        limit: Annotated[int, Query(ge=1, le=queries.MAX_PAGE)] = 50,
    ) -> dict[str, Any]:
        """The plan's parts, oldest first, a page at a time."""
        return queries.parts(engine=engine, plan_id=plan_id, cursor=cursor, page_size=limit)

    @app.get(f"{PREFIX}/plans/{{plan_id}}/history", response_model=schemas.History, tags=["review"])
    def plan_history(plan_id: PlanId, actor: Annotated[Actor, anyone]) -> dict[str, Any]:
        """Every setpoint version with its cause and the bands in force."""
        return queries.plan_history(engine=engine, plan_id=plan_id)

    @app.get(
        f"{PREFIX}/plans/{{plan_id}}/models", response_model=schemas.PlanModels, tags=["review"]
    )
    def plan_models(plan_id: PlanId, actor: Annotated[Actor, anyone]) -> dict[str, Any]:
        """Per operation and quantity the model in force."""
        return queries.models_in_force(engine=engine, plan_id=plan_id)

    @app.get(
        f"{PREFIX}/plans/{{plan_id}}/models/versions",
        response_model=schemas.ModelVersions,
        tags=["review"],
    )
    def model_versions(
        plan_id: PlanId,
        actor: Annotated[Actor, anyone],
        operation: Annotated[str | None, Query(max_length=200, pattern=schemas.NO_NUL)] = None,
        quantity: Annotated[str | None, Query(max_length=50, pattern=schemas.NO_NUL)] = None,
    ) -> dict[str, Any]:
        """Every model version with its cause, optionally of one operation and quantity."""
        return queries.model_versions(
            engine=engine, plan_id=plan_id, operation=operation, quantity=quantity
        )

    @app.get(f"{PREFIX}/tools", response_model=schemas.ToolList, tags=["tools"])
    def list_tools(actor: Annotated[Actor, anyone]) -> dict[str, Any]:
        """The packaged catalogue and the tools added by engineers."""
        return queries.list_tools(engine=engine)

    @app.get(f"{PREFIX}/tools/{{name}}", response_model=schemas.ToolOut, tags=["tools"])
    def get_tool(
        name: Annotated[str, Path(max_length=200, pattern=schemas.NO_NUL)],
        actor: Annotated[Actor, anyone],
    ) -> dict[str, Any]:
        """One tool with its baseline models and their provenance."""
        return queries.get_tool(engine=engine, name=name)

    @app.post(
        f"{PREFIX}/tools",
        status_code=201,
        response_model=schemas.ToolOut,
        tags=["tools"],
        responses={201: {"headers": _REPLAYED}},
    )
    def add_tool(
        request: Request,
        tool: schemas.ToolIn,
        actor: Annotated[Actor, engineer],
        idempotency_key: Annotated[
            str | None, Header(pattern=KEY_PATTERN, description=_KEY_DOC)
        ] = None,
    ) -> Response:
        """Add a tool with its baseline models (a new name; stored tools never change)."""
        body = tool.model_dump(mode="json", exclude_none=True)
        body.setdefault("source", "REST API")  # the reader's default would say "plan file"
        written = tools.add_tool(
            engine=engine,
            body=body,
            actor=actor,
            idempotency=_idempotency(request, idempotency_key, body),
        )
        return _written(written)

    return app


def app_from_env() -> FastAPI:
    """The app on ``$RCB_DATABASE_URL`` (default ``./rcb.db``): the uvicorn worker factory."""
    return create_app(os.environ.get("RCB_DATABASE_URL") or DEFAULT_URL)


_REPLAYED = {
    "Idempotent-Replayed": {
        "description": "`true` when this is the stored response of an earlier request",
        "schema": {"type": "string"},
    }
}

_PLAN_EXAMPLE = {
    "one operation": {
        "summary": "Rough OD of Ivester & Heigel's demonstration part (Table 4 step 1)",
        "value": {
            "name": "demo-rough-od",
            "machine": {"name": "lathe-22kW", "max_power_kW": 22},
            "operations": [
                {
                    "name": "rough-od",
                    "tool": "CNMG432RN",
                    "workpiece_diameter_mm": 60,
                    "volume_mm3": 86400,
                    "limits": {"force_N": 2000, "roughness_um": 4.0},
                    "bounds": {
                        "depth_mm": [0.5, 3.0],
                        "feed_mm_rev": [0.1, 0.6],
                        "speed_m_min": [100, 200],
                    },
                }
            ],
        },
    }
}


def _idempotency(request: Request, key: str | None, body: object) -> idempotency.Idempotency | None:
    # presence (where required) and form were checked by FastAPI: a 400 (api.rest.problems)
    if key is None:
        return None
    return idempotency.Idempotency(key, idempotency.fingerprint("POST", request.url.path, body))


def _written(written: idempotency.Written) -> Response:
    headers = {"Idempotent-Replayed": "true"} if written.replayed else None
    if written.text is not None:  # encoded once, for the database and for this answer
        return Response(
            written.text, written.status, headers=headers, media_type="application/json"
        )
    return JSONResponse(written.body, status_code=written.status, headers=headers)
