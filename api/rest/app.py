"""The REST service the MES calls between parts (FastAPI, under ``/api/v1``).

``create_app(url)`` builds the app on a database and mounts one router per resource
(:mod:`api.rest.routes`); ``app_from_env`` is the factory uvicorn workers import (the
database from :mod:`api.settings`). Routes are thin: authentication and roles
(:mod:`api.rest.deps`), then one use case of :mod:`api.services`.
"""

from __future__ import annotations

from fastapi import FastAPI

from api.report import ui
from api.rest import answers, content_type, documented, problems
from api.rest.head_method import HeadAsGet
from api.rest.lifespan import flushing
from api.rest.limits import BodyLimit
from api.rest.routes import health, parts, plans, review, tools
from api.rest.routes.common import PREFIX
from api.rest.unexpected import UnexpectedAsProblem
from api.rest.writes_in_flight import WritesFirstMiddleware
from api.settings import Settings
from db.engine import DEFAULT_POOL, Pool, make_engine


def create_app(url: str, pool: Pool = DEFAULT_POOL) -> FastAPI:
    """The service on the database at ``url`` (migrated beforehand: ``rcb db upgrade``).

    ``pool``: its database connections; a request that finds none free in time is 503.
    """
    engine = make_engine(url, pool)
    app = FastAPI(
        title="rcb-supervisor",
        version="1",
        summary="Robust cutting parameters, tightened part by part (Recursive Constraint Bounding)",
        openapi_url=f"{PREFIX}/openapi.json",
        docs_url=f"{PREFIX}/docs",
        redoc_url=None,
        lifespan=flushing(engine),  # audit counts written on a timer and at shutdown
    )
    app.state.engine = engine  # the routes' engine (api.rest.deps.engine_of)
    # /api/v1/plans/ is a 404, not a 307 to an absolute URL built from the Host header, which
    # behind a proxy names a host the MES cannot reach (a new user's review)
    app.router.redirect_slashes = False
    problems.install(app)
    content_type.install(app)  # 415 for a body not sent as JSON (api.rest.content_type)
    app.add_middleware(WritesFirstMiddleware)  # reads step aside (api.rest.writes_in_flight)
    app.add_middleware(BodyLimit)  # 413 before a body over 1 MiB is read (api.rest.limits)
    app.add_middleware(UnexpectedAsProblem)  # a 500 keeps the connection (api.rest.unexpected)
    # outermost: a HEAD is its GET without content, for every route (api.rest.head_method)
    app.add_middleware(HeadAsGet)
    ui.install(app, engine)  # the read-only web view at /ui/ (api/report/ui.py)
    for resource in (health, plans, parts, review, tools):
        # the routes as they are, each with its full path: FastAPI 0.165's include_router
        # mounts a router lazily, and a request's route then lacks the prefix (the audit
        # log's action, api.rest.deps.action_of) and a 405 cannot list its methods (Allow)
        app.router.routes.extend(resource.router.routes)
    answers.declare(app)  # each route's problem statuses (api.rest.answers)
    documented.install(app)  # the plan body's schema (api.rest.documented)
    return app


def app_from_env() -> FastAPI:
    """The app on ``$RCB_DATABASE_URL`` (default ``./rcb.db``): the uvicorn worker factory."""
    settings = Settings.from_env()
    return create_app(settings.database_url, settings.pool)
