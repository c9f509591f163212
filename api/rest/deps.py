"""What the routes depend on, through FastAPI's dependency injection: the engine and the actor.

The engine is the app's (``app.state.engine``, set by :func:`api.rest.app.create_app`).
:data:`Anyone` and :data:`Engineer` check the Bearer key of a read or an engineer's write;
:func:`holding` checks the key of a write in the transaction the write goes on in
(:func:`api.services.auth.authenticate_write`).

Authentication failures are counted per client address (:mod:`api.services.throttle`): one
that keeps failing gets 429 with ``Retry-After``. A key scoped to plans gets 404 for any other
plan, as if it did not exist, on every route with a ``{plan_id}`` (:func:`in_scope`).
"""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from collections.abc import AsyncIterator, Callable
from typing import Annotated

from anyio import CancelScope
from fastapi import Depends, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy import Engine

from api.rest.head_method import sent_method
from api.rest.problems import ProblemError
from api.rest.refused_audit import keep_actor
from api.rest.routes.common import MAX_ID
from api.services import auth
from db.api_keys import Actor

_bearer = HTTPBearer(auto_error=False, description="An API key from `rcb keys create`.")
Credentials = Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]


async def engine_of(request: Request) -> Engine:
    """The app's engine (async: resolved on the event loop, no worker thread)."""
    engine: Engine = request.app.state.engine
    return engine


EngineDep = Annotated[Engine, Depends(engine_of)]


def action_of(request: Request) -> str:
    """The audit log's action: the method sent and the route's path template (a bounded set)."""
    route = request.scope.get("route")
    return f"{sent_method(request)} {getattr(route, 'path', '?')}"


def client_of(request: Request) -> str:
    """The client's address, whose authentication failures are counted."""
    return request.client.host if request.client else ""


def too_many(err: auth.RateLimitedError) -> ProblemError:
    """429 for a client address that has failed to authenticate too often."""
    return ProblemError(
        429,
        "too_many_failures",
        str(err),
        "Authorization",
        headers={"Retry-After": str(err.retry_after_s)},
    )


def in_scope(request: Request, actor: Actor) -> None:
    """404 for a plan outside a scoped key's plans, worded as for a plan that does not exist.

    A scoped key writes only to its plans: a write to no plan (``POST /plans``,
    ``POST /tools``) is 403, so it cannot create what it could not then see.
    """
    if actor.plans is None:
        return
    raw = request.path_params.get("plan_id")
    if raw is None:
        if request.method not in ("GET", "HEAD"):
            raise ProblemError(
                403,
                "forbidden",
                "a key scoped to plans writes only to its plans",
                "Authorization",
                sorted(actor.plans),
            )
        return
    try:
        plan_id = int(raw)
    except ValueError:
        return  # not an id: the route's validation answers, as for an unscoped key
    if 1 <= plan_id <= MAX_ID and not actor.may_see(plan_id):
        raise ProblemError(
            404, "not_found", f"plan_id = {plan_id!r}: not found", "plan_id", plan_id
        )


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
    """``actor`` if its role is ``allowed``; else 401 (no actor) or 403 (audited).

    The plan scope is checked by the caller (:func:`in_scope`), after the role.
    """
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
        try:
            actor = auth.authenticate(
                engine=engine, key=key, action=action, client=client_of(request)
            )
        except auth.RateLimitedError as err:
            raise too_many(err) from None
        checked = allowed_actor(engine, actor, key, action, allowed)
        in_scope(request, checked)
        keep_actor(request, checked)  # a refused body is audited as its actor's
        return checked

    check.allowed_roles = allowed  # type: ignore[attr-defined]  # read by api.rest.answers
    return check


def holding(*allowed: str) -> Callable[..., AsyncIterator[auth.Authenticated]]:
    """As :func:`role`, keeping the key's transaction for the write (auth.authenticated).

    The key is checked in a worker thread; the route gives the connection back itself
    (in its own thread), so the usual case needs no third hop to a thread to end the
    request; a request that never reached the route is released here.
    """

    def open_checked(
        request: Request, engine: Engine, key: str | None, idempotency_key: str | None
    ) -> auth.Authenticated:
        action = action_of(request)
        try:
            held = auth.authenticate_write(
                engine=engine,
                key=key,
                action=action,
                idempotency_key=idempotency_key,
                client=client_of(request),
            )
        except auth.RateLimitedError as err:
            raise too_many(err) from None
        if held is None:
            raise unauthorized(key)
        try:
            allowed_actor(engine, held.actor, key, action, allowed, held)
            in_scope(request, held.actor)
            keep_actor(request, held.actor, held)  # a refused body is audited as its actor's
        except BaseException:
            held.close()
            raise
        return held

    async def check(
        request: Request, engine: EngineDep, credentials: Credentials
    ) -> AsyncIterator[auth.Authenticated]:
        key = credentials.credentials if credentials else None
        held = await run_in_threadpool(
            open_checked, request, engine, key, request.headers.get("Idempotency-Key")
        )
        try:
            yield held
        finally:
            if held.session is not None:  # the route did not run (a refused body)
                with CancelScope(shield=True):
                    await run_in_threadpool(held.close)

    check.allowed_roles = allowed  # type: ignore[attr-defined]  # read by api.rest.answers
    return check


#: Any role may read.
Anyone = Annotated[Actor, Depends(role("mes", "engineer", "viewer"))]
#: Engineers only.
Engineer = Annotated[Actor, Depends(role("engineer"))]
#: The MES or an engineer, holding the key's transaction for a part report.
Reporter = Annotated[auth.Authenticated, Depends(holding("mes", "engineer"))]
