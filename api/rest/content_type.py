"""JSON bodies only: a body sent as anything but ``application/json`` is answered 415.

curl's ``-d`` sends ``application/x-www-form-urlencoded``; FastAPI then validates the raw bytes
and answers 422 "Input should be a valid dictionary" with the body echoed, which does not say
what to change. Here a route that takes a JSON body (one with a body parameter) refuses, before
the body is read, a request that carries a body (a ``Content-Length`` over 0, or chunked) with
another media type or none, as an RFC 9457 problem (:func:`api.rest.problems.problem`), code
``unsupported_media_type``, field ``Content-Type``, and an ``Accept-Post`` header (RFC 9110
§15.5.16) naming what to send.

Accepted: ``application/json``, with no parameter or ``charset=utf-8`` (RFC 8259 §8.1: JSON
exchanged between systems is UTF-8; any other charset is refused, since the body would be read
as UTF-8 regardless). Refused: ``+json`` types such as ``application/problem+json``, though
their syntax is JSON, because the media type names what the document *is*: a problem report is
not a plan, and the OpenAPI document declares ``application/json`` only.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from starlette.requests import Request
from starlette.routing import Match
from starlette.types import ASGIApp, Receive, Scope, Send

from api.rest import problems

#: The one media type a request body may have.
JSON = "application/json"
_WRITES = frozenset({"POST", "PUT", "PATCH"})
_STATUS = 415
_DESCRIPTION = "The body is not sent as `application/json`"


class JsonBodies:
    """ASGI middleware refusing a non-JSON body of a JSON route with 415 problem+json."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass everything but a body of another media type to a route that takes JSON."""
        if scope["type"] != "http" or scope["method"] not in _WRITES or not _has_body(scope):
            await self.app(scope, receive, send)
            return
        sent = _header(scope, b"content-type")
        if accepted(sent) or not _takes_json(scope):
            await self.app(scope, receive, send)
            return
        shown = "no Content-Type" if sent is None else f"Content-Type {sent!r}"
        detail = (
            f"the body is sent with {shown}; send it as JSON with "
            f"'Content-Type: {JSON}' (curl: -H 'Content-Type: {JSON}' or --json)"
        )
        response = problems.problem(
            Request(scope),
            _STATUS,
            "unsupported_media_type",
            detail,
            "Content-Type",
            sent,
            headers={"Accept-Post": JSON},
        )
        await response(scope, receive, send)


def accepted(content_type: str | None) -> bool:
    """Whether ``content_type`` is JSON as the service reads it (see the module's docstring)."""
    if content_type is None:
        return False
    media, *params = (part.strip() for part in content_type.split(";"))
    if media.lower() != JSON:
        return False
    for param in params:
        name, _, value = param.partition("=")
        if name.strip().lower() != "charset" or value.strip().strip('"').lower() != "utf-8":
            return False
    return True


def install(app: FastAPI) -> None:
    """Refuse non-JSON bodies (:class:`JsonBodies`) and document the 415 on each JSON route."""
    app.add_middleware(JsonBodies)
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        document = generate()
        for item in document.get("paths", {}).values():
            for operation in item.values():
                if isinstance(operation, dict) and "requestBody" in operation:
                    operation.setdefault("responses", {})[str(_STATUS)] = _response()
        return document

    app.openapi = openapi  # type: ignore[method-assign]


def _response() -> dict[str, Any]:
    schema = {"$ref": "#/components/schemas/Problem"}
    return {
        "description": _DESCRIPTION,
        "headers": {
            "Accept-Post": {
                "description": "the media type to send the body as",
                "schema": {"type": "string"},
            }
        },
        "content": {problems.MEDIA_TYPE: {"schema": schema}},
    }


def _takes_json(scope: Scope) -> bool:
    """Whether the route the request goes to has a body parameter (FastAPI's ``body_field``)."""
    app = scope.get("app")
    for route in getattr(getattr(app, "router", None), "routes", ()):
        match, _ = route.matches(scope)
        if match is Match.FULL:
            return getattr(route, "body_field", None) is not None
    return False


def _has_body(scope: Scope) -> bool:
    length = _header(scope, b"content-length")
    if length is not None:
        return not length.strip().isdigit() or int(length.strip()[:19]) > 0
    return _header(scope, b"transfer-encoding") is not None


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", ()):
        if key == name:
            return bytes(value).decode("latin-1")
    return None
