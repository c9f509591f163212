"""Bounded requests: a body over :data:`MAX_BODY_BYTES` is answered 413 before it is parsed.

A declared ``Content-Length`` over the limit is refused at once, before a byte of the body is
read; a body without one (chunked) is counted as it arrives and refused at the first chunk past
the limit. Either way the app never holds more than the limit of a body, and the answer is an
RFC 9457 problem (:func:`api.rest.problems.problem`), code ``body_too_large``.
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from api.rest import problems
from models.bounds import MAX_DOCUMENT_BYTES

#: The largest request body the service reads [bytes]: :data:`models.bounds.MAX_DOCUMENT_BYTES`,
#: 1 MiB, the bound of a plan file too (a plan of a hundred operations is some 100 kB, a part
#: report a few kB).
MAX_BODY_BYTES = MAX_DOCUMENT_BYTES


class BodyLimit:
    """ASGI middleware refusing request bodies over ``max_bytes`` with 413 problem+json."""

    def __init__(self, app: ASGIApp, max_bytes: int = MAX_BODY_BYTES) -> None:
        self.app, self.max_bytes = app, max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Refuse a declared length over the limit; count an undeclared one as it arrives."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = _content_length(scope)
        if declared is not None and declared > self.max_bytes:
            await self._refuse(scope, receive, send, declared)
            return
        received = 0
        over = started = False

        async def counted() -> Message:
            nonlocal received, over
            if over:  # asked again after the cut: to the app, the client is gone
                return {"type": "http.disconnect"}
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:  # a body longer than declared, or chunked
                    over = True
                    return {"type": "http.disconnect"}
            return message

        async def guarded(message: Message) -> None:
            nonlocal started
            if over and not started:
                return  # the app's answer to a cut body: the 413 replaces it
            started = started or message["type"] == "http.response.start"
            await send(message)

        await self.app(scope, counted, guarded)
        if over and not started:
            await self._refuse(scope, receive, send, None)

    async def _refuse(
        self, scope: Scope, receive: Receive, send: Send, declared: int | None
    ) -> None:
        size = "" if declared is None else f" ({declared} bytes)"
        detail = f"the request body{size} is over the limit of {self.max_bytes} bytes"
        response = problems.problem(
            Request(scope), 413, "body_too_large", detail, "body", headers={"Connection": "close"}
        )
        await response(scope, receive, send)


def _content_length(scope: Scope) -> int | None:
    """The declared body length; None when none is declared (chunked, no body) or garbled.

    A length of more than 18 digits is taken as 10**18: over any limit, never parsed whole.
    """
    for name, value in scope.get("headers", ()):
        if name == b"content-length":
            text = value.strip()
            if not text.isdigit():
                return None  # the HTTP server refuses it; the count below still holds
            return int(text) if len(text) <= 18 else 10**18
    return None
