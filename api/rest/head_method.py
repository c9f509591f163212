"""ASGI middleware: a HEAD request is answered as its GET, without the content.

RFC 9110 §9.1: a general-purpose server MUST support HEAD; §9.3.2: HEAD is GET without the
content, with the same status and header fields. FastAPI's routes take only the methods they
declare, so ``HEAD /api/v1/health`` was 405 (``Allow: GET``) and load balancers and uptime
probes that send HEAD marked the service down.

:class:`HeadAsGet` hands the app a HEAD as a GET (a copy of the request's scope: the server
still sees HEAD, and logs it) and sends the answer's status and header fields as they are,
``content-length`` and ``content-type`` included, with the content dropped. Everything the
GET goes through, a HEAD goes through: authentication (a wrong key is 401), the throttle, the
query checks, the problems (404, 422, 405 with ``Allow`` on a path that has no GET, as
``HEAD /api/v1/plans/1/replan``). The web view (``/ui``) is served by the same app and
answers HEAD too. Other methods, OPTIONS among them, are passed on untouched. The OpenAPI
document lists the GET operations only. The scope the app sees keeps the method sent under
:data:`SENT_METHOD`, so the audit log names a HEAD as what it was (:func:`sent_method`).
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.types import ASGIApp, Message, Receive, Scope, Send

#: The scope's key holding the method a client sent, where it was handed on as another.
SENT_METHOD = "rcb.sent_method"


def sent_method(request: Request) -> str:
    """The method the client sent: HEAD for a HEAD answered as its GET."""
    method: str = request.scope.get(SENT_METHOD, request.method)
    return method


class HeadAsGet:
    """Wraps the app: a HEAD runs as a GET and its answer goes out without content."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass a HEAD on as a GET whose content is dropped; any other request as it is."""
        if scope["type"] != "http" or scope["method"] != "HEAD":
            await self.app(scope, receive, send)
            return

        async def without_content(message: Message) -> None:
            if message["type"] == "http.response.body":
                message = {**message, "body": b""}
            await send(message)

        # a copy: the server's scope keeps HEAD, so it sends no content whatever it is given
        await self.app({**scope, "method": "GET", SENT_METHOD: "HEAD"}, receive, without_content)
