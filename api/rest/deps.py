"""What the routes depend on, through FastAPI's dependency injection: the engine and the actor.

The engine is the app's (``app.state.engine``, set by :func:`api.rest.app.create_app`).
:data:`Anyone` and :data:`Engineer` check the Bearer key of a read or an engineer's write;
:func:`holding` checks the key of a write in the transaction the write goes on in
(:func:`api.services.auth.authenticate_write`).
"""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from collections.abc import AsyncIterator, Callable
from typing import Annotated

from anyio import CancelScope
from fastapi import Depends, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy import Engine

from api.rest.problems import ProblemError
from api.services import auth
from db.access import Actor

_bearer = HTTPBearer(auto_error=False, description="An API key from `rcb keys create`.")
Credentials = Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]


async def engine_of(request: Request) -> Engine:
    """The app's engine (async: resolved on the event loop, no worker thread)."""
    engine: Engine = request.app.state.engine
    return engine


EngineDep = Annotated[Engine, Depends(engine_of)]


def action_of(request: Request) -> str:
    """The audit log's action: the method and the route's path template (a bounded set)."""
    route = request.scope.get("route")
    return f"{request.method} {getattr(route, 'path', '?')}"


def unauthorized(key: str | None) -> ProblemError:
    """401 for a missing, unknown or revoked key."""
    return ProblemError(
        401,
        "unauthorized",
        "missing API key" if key is None else "unknown or revoked API key",
        "Authorization",
        headers={"WWW-Authenticate": "Bearer"},
    )


def allowed_actor(
    engine: Engine,
    actor: Actor | None,
    key: str | None,
    action: str,
    allowed: tuple[str, ...],
    held: auth.Authenticated | None = None,
) -> Actor:
    """``actor`` if its role is ``allowed``; else 401 (no actor) or 403 (audited)."""
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
    """A dependency: the actor of the request's key, if its role is one of ``allowed``."""

    def check(request: Request, engine: EngineDep, credentials: Credentials) -> Actor:
        action = action_of(request)
        key = credentials.credentials if credentials else None
        actor = auth.authenticate(engine=engine, key=key, action=action)
        return allowed_actor(engine, actor, key, action, allowed)

    return check


def holding(*allowed: str) -> Callable[..., AsyncIterator[auth.Authenticated]]:
    """As :func:`role`, keeping the key's transaction for the write (auth.authenticated).

    The key is checked in a worker thread; the route gives the connection back itself
    (in its own thread), so the usual case needs no third hop to a thread to end the
    request; a request that never reached the route is released here.
    """

    def open_checked(
        engine: Engine, key: str | None, action: str, idempotency_key: str | None
    ) -> auth.Authenticated:
        held = auth.authenticate_write(
            engine=engine, key=key, action=action, idempotency_key=idempotency_key
        )
        if held is None:
            raise unauthorized(key)
        try:
            allowed_actor(engine, held.actor, key, action, allowed, held)
        except BaseException:
            held.close()
            raise
        return held

    async def check(
        request: Request, engine: EngineDep, credentials: Credentials
    ) -> AsyncIterator[auth.Authenticated]:
        key = credentials.credentials if credentials else None
        held = await run_in_threadpool(
            open_checked, engine, key, action_of(request), request.headers.get("Idempotency-Key")
        )
        try:
            yield held
        finally:
            if held.session is not None:  # the route did not run (a refused body)
                with CancelScope(shield=True):
                    await run_in_threadpool(held.close)

    return check


#: Any role may read.
Anyone = Annotated[Actor, Depends(role("mes", "engineer", "viewer"))]
#: Engineers only.
Engineer = Annotated[Actor, Depends(role("engineer"))]
#: The MES or an engineer, holding the key's transaction for a part report.
Reporter = Annotated[auth.Authenticated, Depends(holding("mes", "engineer"))]
