"""HTTP connections that cannot be held forever: deadlines, and caps per client and in total.

uvicorn (0.54) closes a kept-alive connection idle after a response (``timeout_keep_alive``)
but sets no deadline on a connection that never sends a byte, nor on a request's head or body
sent slowly (slowloris), and its ``limit_concurrency`` answers 503 to every request once that
many connections are open, the MES's too. Issue 29: 300 slowloris connections still open after
50 s, 40 silent ones after 90 s, and 1100 half-sent requests used up the worker's 1024 open
files, so the MES could not connect at all.

:class:`GuardedProtocol` is uvicorn's httptools protocol with what a front server (nginx
``client_header_timeout``, ``client_body_timeout``, ``limit_conn``,
``large_client_header_buffers``; Apache ``mod_reqtimeout`` and the event MPM, which closes idle
kept-alive connections when it runs out of room) does:

- a request's head (request line and header fields) is at most 32 KiB, else 431 or 414
  problem+json before the app sees it (:mod:`api.rest.heads`);

- a request's head must be complete within ``header_timeout_s`` of the connection's opening,
  or of its first byte on a kept-alive connection, and its body within ``body_timeout_s`` of
  the head: a deadline for the whole, not per read, so a byte now and then does not renew it;
  then the connection is closed;
- a client address holds at most ``per_client`` connections: more are answered 503 and closed
  at once, so one address cannot take the others' room;
- a worker holds at most ``total`` connections, below its open-file limit (:func:`total_cap`):
  a new one then closes the oldest connection still waiting for a request's head (idle, or
  half-sent), never one whose request is being served; if there is none, it is refused.

The deadlines do not apply while the app computes an answer or the answer is sent. The caps are
per worker process (``--workers N`` allows N times as many).
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time
from collections import Counter, OrderedDict
from functools import cache
from typing import Any

from api.rest.heads import HeadLimit
from api.settings import HttpLimits, http_limits

#: The ``http`` of uvicorn's config: this module's protocol, imported by name in each worker.
PROTOCOL = "api.rest.connections:GuardedProtocol"
#: Open files a worker keeps for itself beside its connections (database pool, logs, imports).
RESERVED_FILES = 128
#: Seconds between two log lines about refused or closed connections.
LOG_EVERY_S = 10.0
_REFUSED_BODY = (
    b'{"type":"urn:rcb-supervisor:problem:too_many_connections","title":"Service unavailable",'
    b'"status":503,"detail":"too many connections from this address or to this server; retry '
    b'later","code":"too_many_connections"}'
)
_REFUSED = (
    b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/problem+json\r\n"
    b"retry-after: 1\r\nconnection: close\r\ncontent-length: %d\r\n\r\n%s"
    % (len(_REFUSED_BODY), _REFUSED_BODY)
)
_log = logging.getLogger("rcb.api.connections")


def total_cap(limits: HttpLimits) -> int:
    """The connections a worker holds at once.

    ``limits.total``, else its open-file limit (soft ``RLIMIT_NOFILE``) less
    :data:`RESERVED_FILES`, at least 16.
    """
    if limits.total is not None:
        return limits.total
    soft, _hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    return max(16, (soft if soft != resource.RLIM_INFINITY else 65536) - RESERVED_FILES)


def raise_file_limit(ceiling: int = 65536) -> int:
    """Raise this process's soft open-file limit to its hard limit, at most ``ceiling``.

    As servers do at start (nginx ``worker_rlimit_nofile``); the workers inherit it. Returns
    the soft limit now.
    """
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    wanted = ceiling if hard == resource.RLIM_INFINITY else min(hard, ceiling)
    if soft != resource.RLIM_INFINITY and soft < wanted:
        resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
        return wanted
    return soft


class _Ledger:
    """The connections of this worker: per client address, in total, and which are waiting."""

    def __init__(self) -> None:
        self.per_client: Counter[str] = Counter()
        self.total = 0
        self.waiting: OrderedDict[GuardedProtocol, None] = OrderedDict()  # oldest first
        self.refused = self.evicted = self.expired = 0
        self._logged_s = 0.0

    def admit(self, connection: GuardedProtocol, limits: HttpLimits) -> bool:
        """Count ``connection`` in; False if it is to be refused (its client or all are full)."""
        if self.per_client[connection.host] >= limits.per_client:
            return self._note("refused")
        if self.total >= total_cap(limits):
            if not self.waiting:
                return self._note("refused")
            oldest, _ = self.waiting.popitem(last=False)
            oldest.drop("evicted")
        self.per_client[connection.host] += 1
        self.total += 1
        return True

    def release(self, connection: GuardedProtocol) -> None:
        """Count ``connection`` out (once)."""
        self.waiting.pop(connection, None)
        self.total -= 1
        self.per_client[connection.host] -= 1
        if self.per_client[connection.host] <= 0:
            del self.per_client[connection.host]

    def _note(self, what: str) -> bool:
        setattr(self, what, getattr(self, what) + 1)
        now = time.monotonic()
        if now - self._logged_s >= LOG_EVERY_S:
            self._logged_s = now
            _log.warning(
                "connections: %d open; so far %d refused (client or worker full), %d idle or "
                "half-sent closed to make room, %d closed at their deadline",
                self.total, self.refused, self.evicted, self.expired,
            )  # fmt: skip
        return False


LEDGER = _Ledger()


@cache
def _limits() -> HttpLimits:
    return http_limits()  # the worker's environment, checked by rcb serve before serving


class GuardedProtocol(HeadLimit):
    """uvicorn's httptools protocol with deadlines and connection caps (module docstring).

    And a bounded request head (:class:`api.rest.heads.HeadLimit`: 431 or 414 past 32 KiB).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.limits = _limits()
        self.host = ""
        self._counted = False
        self._deadline: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        """Admit the connection (or refuse it) and start the deadline of its first head."""
        super().connection_made(transport)
        self.host = self.client[0] if self.client else ""
        if not LEDGER.admit(self, self.limits):
            transport.write(_REFUSED)
            transport.close()
            return
        self._counted = True
        self._waiting()
        self._arm(self.limits.header_timeout_s)

    def connection_lost(self, exc: Exception | None) -> None:
        """Count the connection out and forget its deadline."""
        self._release()
        super().connection_lost(exc)

    def on_message_begin(self) -> None:
        """A request's first byte: its head's deadline starts (unless already running)."""
        super().on_message_begin()
        if self._deadline is None:
            self._arm(self.limits.header_timeout_s)

    def on_headers_complete(self) -> None:
        """The head is in: the request is served (never evicted); its body's deadline starts."""
        LEDGER.waiting.pop(self, None)
        self._arm(self.limits.body_timeout_s)
        super().on_headers_complete()

    def on_message_complete(self) -> None:
        """The body is in: no deadline while the app answers."""
        self._disarm()
        super().on_message_complete()

    def on_response_complete(self) -> None:
        """Answered: waiting for the next request (uvicorn's keep-alive timeout runs)."""
        super().on_response_complete()
        if self._counted and not self.transport.is_closing() and not self.pipeline:
            self._waiting()

    def drop(self, why: str) -> None:
        """Close the connection now (``why``: ``evicted`` or ``expired``, for the log)."""
        setattr(LEDGER, why, getattr(LEDGER, why) + 1)
        self._release()
        if not self.transport.is_closing():
            self.transport.close()

    def _waiting(self) -> None:
        if self._counted:
            LEDGER.waiting[self] = None

    def _arm(self, seconds: float) -> None:
        self._disarm()
        self._deadline = self.loop.call_later(seconds, self.drop, "expired")

    def _disarm(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None

    def _release(self) -> None:
        self._disarm()
        if self._counted:
            self._counted = False
            LEDGER.release(self)
