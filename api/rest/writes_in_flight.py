"""ASGI middleware: every request that is not a read counts as a write in flight.

While it is in flight, long reads pause at their next step (:mod:`api.services.writes_first`),
so the MES's part reports keep their pace when engineers page through history.

A write counts from the moment its whole body has arrived, not from its first byte: a client
that opens a POST and never finishes its body (a slow or stalled one, or one with no key at
all) would otherwise hold every read of the process at its pauses until the server's timeout
(a lockout review: one such POST made reads about 80 times slower).
"""

from __future__ import annotations

from contextlib import ExitStack

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from api.services.writes_first import GATE

_READS = frozenset({"GET", "HEAD", "OPTIONS"})


class WritesFirstMiddleware:
    """Wraps the app: a POST (PUT, PATCH, DELETE) is counted from its body to its answer."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass the request on, counted as a write once its body is in, unless it is a read."""
        if scope["type"] != "http" or scope["method"] in _READS:
            await self.app(scope, receive, send)
            return
        with ExitStack() as counted:
            started = False

            async def body_then_count() -> Message:
                nonlocal started
                message = await receive()
                whole = message["type"] == "http.request" and not message.get("more_body")
                if whole and not started:
                    started = True
                    counted.enter_context(GATE.writing())
                return message

            await self.app(scope, body_then_count, send)
