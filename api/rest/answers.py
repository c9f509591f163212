"""The problem statuses each operation can answer, as its OpenAPI document declares them.

A generated client decodes only what the document declares: an undeclared status is an
``UnexpectedStatus`` to it, a declared one it cannot answer a case it must handle for nothing.
So each operation declares what its route can send, derived from what the route has
(:func:`statuses_of`), plus what its use case may refuse, which the route names itself
(:func:`problems_at`: 409 for a halted plan, 500 for a solver failure):

- every route: 413, a body over the limit (:mod:`api.rest.limits` reads every request); 414
  and 431, a request line or header fields over the head's limit, and 400 a request the HTTP
  parser refuses (``rcb serve``'s connections, :mod:`api.rest.heads`, before the app reads the
  request);
- a key: 401 (none, unknown, revoked), 429 (too many failures, :mod:`api.services.throttle`),
  403 where a role may not (or a key scoped to plans writes to no plan, :mod:`api.rest.deps`);
- a path parameter: 404 (no such plan or tool, or a plan outside a scoped key);
- parameters or a body: 422 (invalid, or a query parameter the route does not take), 400 (a
  query parameter given twice, an Idempotency-Key malformed or missing, a body that is empty
  or not UTF-8 JSON, :mod:`api.rest.strict`);
- a write: 409 (the same thing stored by a concurrent request, a request still in flight);
- every route: 503 with ``Retry-After``: the database has no connection free
  (:mod:`api.rest.unavailable`), or ``rcb serve`` holds too many connections
  (:mod:`api.rest.connections`, before the app reads the request).

415 (a body not sent as JSON) is declared by :mod:`api.rest.content_type`, with its header.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.dependencies.models import Dependant
from fastapi.routing import APIRoute
from fastapi.utils import create_model_field

from api.rest.heads import MAX_HEAD_BYTES
from api.rest.limits import MAX_BODY_BYTES
from api.rest.problems import MEDIA_TYPE
from api.rest.schemas.service import Problem
from db.api_keys import ROLES

#: What each status means, as its response's description.
MEANINGS = {
    400: "Bad request: a query parameter given twice, an Idempotency-Key malformed or missing, "
    "a body that is empty or not UTF-8 JSON, or (`malformed_request`, before any operation) a "
    "request that is not valid HTTP/1.1; the connection is then closed",
    401: "No API key, or an unknown or revoked one",
    403: "The key's role may not do this (or a key scoped to plans writes to no plan)",
    404: "No such resource (a plan outside a key's scope answers so too)",
    409: "Conflict: see `code` (a halted plan, a name or serial taken, a request in flight)",
    413: f"The request body is over the limit of {MAX_BODY_BYTES // 2**20} MiB",
    414: f"The request line (its URL) is over the request head's limit of "
    f"{MAX_HEAD_BYTES // 2**10} KiB; the connection is closed",
    422: "Invalid input: `field` and `value` name it (`errors`: every one); `infeasible`: "
    "`conflicts` names the limits that cannot all be met",
    429: "Too many failed authentications from this address; wait `Retry-After` seconds",
    431: f"The request's header fields are over the head's limit of {MAX_HEAD_BYTES // 2**10} "
    "KiB (`field`: the one alone over half of it, else `headers`); the connection is closed",
    500: "The solver failed; nothing was stored",
    503: "The database has no connection free now, or (`too_many_connections`) the server "
    "holds too many connections; nothing was stored; retry after `Retry-After` seconds",
}
_RETRY_AFTER = {"description": "seconds to wait", "schema": {"type": "integer"}}
_HEADERS: dict[int, dict[str, Any]] = {
    401: {"WWW-Authenticate": {"description": "`Bearer`", "schema": {"type": "string"}}},
    429: {"Retry-After": _RETRY_AFTER},
    503: {"Retry-After": _RETRY_AFTER},
}
_WRITES = frozenset({"POST", "PUT", "PATCH", "DELETE"})


def problems_at(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """The ``responses`` of a route decorator: a problem+json answer for each status."""
    out: dict[int | str, dict[str, Any]] = {}
    for status in statuses:
        response: dict[str, Any] = {
            "model": Problem,
            "description": MEANINGS[status],
            "content": {MEDIA_TYPE: {}},  # the schema moves here (api.rest.problems._document)
        }
        if status in _HEADERS:
            response["headers"] = _HEADERS[status]
        out[status] = response
    return out


def _roles(dependant: Dependant) -> set[str] | None:
    """The roles the route's key check allows (None: the route takes no key)."""
    allowed: set[str] | None = None
    for sub in dependant.dependencies:
        found = getattr(sub.call, "allowed_roles", None)
        if found is not None:
            allowed = set(found) if allowed is None else allowed & set(found)
        deeper = _roles(sub)
        if deeper is not None:
            allowed = deeper if allowed is None else allowed & deeper
    return allowed


def statuses_of(route: APIRoute) -> set[int]:
    """The problem statuses ``route`` can answer, from its parameters, key and method."""
    query, header, path = (_any(route.dependant, kind) for kind in ("query", "header", "path"))
    methods = route.methods or set()
    # 400: a request the parser refuses; 414, 431: a head over the limit; 503: rcb serve's
    # too_many_connections too (api.rest.heads, api.rest.connections: before any route)
    found = {400, 413, 414, 431, 503}
    roles = _roles(route.dependant)
    if roles is not None:
        found |= {401, 429}
        scoped_write = bool(methods & _WRITES) and "plan_id" not in route.param_convertors
        if set(ROLES) - roles or scoped_write:
            found.add(403)
    if path:
        found.add(404)
    if query or header or route.body_field is not None:
        found |= {400, 422}
    elif path:
        found.add(422)
    if methods & _WRITES:
        found.add(409)
    return found


def _any(dependant: Dependant, kind: str) -> bool:
    """Whether the route or a dependency of it takes a ``kind`` (query, header, path) parameter."""
    return bool(getattr(dependant, f"{kind}_params")) or any(
        _any(sub, kind) for sub in dependant.dependencies
    )


def declare(app: FastAPI) -> None:
    """Add to each API route of ``app`` the problem answers it can send (before the document)."""
    for route in app.routes:
        if isinstance(route, APIRoute):
            for status, response in problems_at(*sorted(statuses_of(route))).items():
                if status in route.responses:
                    continue  # the route's own, more precise
                route.responses[status] = response
                # what FastAPI builds from a decorator's responses: the model's schema
                route.response_fields[status] = create_model_field(
                    name=f"Response_{status}_{route.unique_id}", type_=Problem, mode="serialization"
                )
