"""A write whose body the route's schema refused, in the audit log as the service's refusals are.

``docs/guide/rest-service.md``: every write, refused write and authentication failure is
appended to ``audit_log``. A part report refused by the service's reader (an unknown operation)
was; one refused by the schema before it (a negative force, NaN, a missing field: 422; malformed
JSON: 400) was not, so a sensor that sent NaN all shift left no trace in ``rcb audit``. The
key's dependency (:mod:`api.rest.deps`) keeps the actor on the request; the validation handler
(:mod:`api.rest.problems`) appends the refusal, in the request's own connection where it still
holds one. A body refused before its key is read (413, 415) has no actor and is not logged.
"""

from __future__ import annotations

from typing import Any

from fastapi import Request
from fastapi.concurrency import run_in_threadpool

from api.services.auth import Authenticated, aside
from db import audit
from db.api_keys import Actor
from db.tables import MAX_INT as MAX_ID

#: The methods that write.
WRITES = ("POST", "PUT", "PATCH", "DELETE")
#: Each write route's action, as the service audits the writes it refuses (``rcb audit
#: --action``); a route not here is named by its method and path.
ACTIONS = {
    "POST /api/v1/plans/{plan_id}/parts": "report part",
    "POST /api/v1/plans": "create plan",
    "POST /api/v1/plans/{plan_id}/replan": "replan",
    "POST /api/v1/tools": "add tool",
}


def keep_actor(request: Request, actor: Actor, held: Authenticated | None = None) -> None:
    """Keep the request's actor (and its held connection) for :func:`audit_refused`."""
    request.state.actor, request.state.held = actor, held


async def audit_refused(request: Request, code: str, field: str | None, message: str) -> None:
    """Append a write the schema refused (``code``: the problem's) to the audit log."""
    actor: Actor | None = getattr(request.state, "actor", None)
    if actor is None or request.method not in WRITES:
        return
    raw = request.path_params.get("plan_id")
    plan_id = int(raw) if isinstance(raw, str) and raw.isdigit() and len(raw) <= 10 else None
    detail = {"error": code, "field": field or "", "message": message[:500]}
    route = request.scope.get("route")
    path = f"{request.method} {getattr(route, 'path', request.url.path)}"
    action = ACTIONS.get(path, path)
    await run_in_threadpool(
        _append, request, actor, action, detail, plan_id if plan_id and plan_id <= MAX_ID else None
    )


def _append(
    request: Request, actor: Actor, action: str, detail: dict[str, Any], plan_id: int | None
) -> None:
    held: Authenticated | None = getattr(request.state, "held", None)
    session = held.session if held is not None else None  # None once given back
    with aside(request.app.state.engine, session) as written:
        audit.audit(
            session=written,
            actor=actor.name,
            action=action,
            target=f"plan {plan_id}" if plan_id else request.url.path,
            result="refused",
            detail=detail,
            plan_id=plan_id,
        )
