"""An error no handler takes: the 500 problem, on a connection the client may use again.

Starlette hands an exception no handler of :mod:`api.rest.problems` takes to its outermost
middleware, which sends the 500 and raises the error again; uvicorn, seeing an error after the
response started, closes the connection without ``Connection: close``, and a client's next
request on it (an MES retrying, or reading ``/health``) failed as "connection reset by peer"
(an MES integrator's audit). This middleware, inside that one, sends the same 500
(:func:`api.rest.problems.unexpected`, logged with its traceback) and ends the request there.
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from api.rest.problems import unexpected


class UnexpectedAsProblem:
    """Pure ASGI middleware: an exception raised before the response started is a 500 problem."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Serve the request; answer an error raised before the response started."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def sending(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, receive, sending)
        except Exception as err:
            if started:  # a response half sent cannot become a problem: uvicorn closes it
                raise
            response = await unexpected(Request(scope, receive), err)
            await response(scope, receive, send)
