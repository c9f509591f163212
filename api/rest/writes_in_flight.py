"""ASGI middleware: every request that is not a read counts as a write in flight.

While it is in flight, long reads pause at their next step (:mod:`api.services.writes_first`),
so the MES's part reports keep their pace when engineers page through history.
"""

from __future__ import annotations

from starlette.types import ASGIApp, Receive, Scope, Send

from api.services.writes_first import GATE

_READS = frozenset({"GET", "HEAD", "OPTIONS"})


class WritesFirstMiddleware:
    """Wraps the app: a POST (PUT, PATCH, DELETE) is counted from its arrival to its answer."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass the request on, counted as a write unless it is a read."""
        if scope["type"] != "http" or scope["method"] in _READS:
            await self.app(scope, receive, send)
            return
        with GATE.writing():
            await self.app(scope, receive, send)
