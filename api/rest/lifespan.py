"""What the service does besides answering requests: its audit counts written on a timer.

Authentication failures are counted in memory and written to their coalesced audit row
(:mod:`api.services.throttle`). Every :data:`api.services.throttle.FLUSH_S` seconds, and once
more when the server shuts down (``SIGTERM``, ``SIGINT``: uvicorn runs the app's lifespan
shutdown after the last request), the counts not yet written are written
(:func:`api.services.auth.flush_failures`), so a burst is counted whole even when nothing
follows it. Only a killed process (``kill -9``) loses counts: at most ``FLUSH_S`` seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager

from fastapi import FastAPI
from fastapi.concurrency import run_in_threadpool
from sqlalchemy import Engine

from api.services.auth import flush_failures
from api.services.throttle import FLUSH_S


def flushing(engine: Engine) -> Callable[[FastAPI], AbstractAsyncContextManager[None]]:
    """The app's lifespan: the failure counts of ``engine`` written on a timer and at the end."""

    @contextlib.asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        timer = asyncio.create_task(_every(FLUSH_S, engine))
        try:
            yield
        finally:
            timer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await timer
            await run_in_threadpool(flush_failures, engine)

    return lifespan


async def _every(period_s: float, engine: Engine) -> None:
    while True:
        await asyncio.sleep(period_s)
        await run_in_threadpool(flush_failures, engine)
