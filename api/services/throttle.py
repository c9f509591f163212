"""Authentication failures: a token bucket per client address, and their coalesced audit rows.

The bucket (:class:`FailureLimiter`) is shared by every instance on the database
(:mod:`db.auth_buckets`; issue 33: before, each worker process kept its own, so N instances
allowed N bursts), with each process's copy answering a flood without asking: a client that
keeps sending wrong keys gets 429 with ``Retry-After`` once its bucket is empty (a missing key
spends nothing: it guesses nothing). The audit log (:class:`FailureLog`, counted over every
instance in :mod:`db.audit_windows`) gets one row per client address, action, reason and
window, whose ``detail.count`` says how many failures it stands for, instead of one row per
failure.
"""

from __future__ import annotations

import math
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

#: Failures a client address may make at once before it is refused with 429.
BURST_FAILURES = 60
#: Failures per second a client address earns back.
REFILL_PER_S = 1.0
#: Length of an audit window [s]: one audit row per client, action and reason in each.
WINDOW_S = 60.0
#: A coalesced row's count is written at most this often [s] while its window lasts.
FLUSH_S = 2.0
#: Client addresses remembered at once (the oldest are forgotten first).
MAX_CLIENTS = 10_000


class RateLimitedError(Exception):
    """Too many authentication failures from one client address; retry after ``retry_after_s``."""

    def __init__(self, client: str, retry_after_s: int) -> None:
        self.field, self.value, self.retry_after_s = "Authorization", client, retry_after_s
        super().__init__(
            f"too many authentication failures from {client}; retry after {retry_after_s} s"
        )


#: ``shared(client, now_s, period_s, tolerance_s)``: spend one failure of ``client`` in the
#: bucket every instance shares (:func:`db.auth_buckets.spend`): None when it had one left,
#: else the shared theoretical arrival time [s] that refused it.
Shared = Callable[[str, float, float, float], "float | None"]


class FailureLimiter:
    """A token bucket per client address, spent by authentication failures.

    Kept as the generic cell rate algorithm (GCRA: one time per client instead of a count and
    a time, ITU-T I.371; the same decisions as the bucket): with the period ``T = 1 /
    refill_per_s`` and the tolerance ``τ = (burst − 1) T``, a failure at ``now`` is allowed
    when ``max(tat, now) − now <= τ`` and then moves ``tat`` to ``max(tat, now) + T``; a
    refused one waits ``max(tat, now) − τ − now``. ``burst`` failures pass at once, then one
    per ``T``. With ``shared`` (several instances on one database) the time lives in the
    database, and this process keeps the latest it saw: a failure its copy already refuses is
    refused without asking (the shared time is never earlier), so a flood costs the database
    one statement per period and client, not one per request.

    Parameters
    ----------
    burst : int
        Failures allowed at once (the bucket's size).
    refill_per_s : float
        Failures per second earned back [1/s].
    clock : callable
        Time [s]: wall-clock, as every instance of a shared bucket must read the same (a test
        passes its own).
    """

    def __init__(
        self,
        burst: int = BURST_FAILURES,
        refill_per_s: float = REFILL_PER_S,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.burst, self.refill_per_s, self.clock = burst, refill_per_s, clock
        self._tat: OrderedDict[str, float] = OrderedDict()
        self._lock = threading.Lock()

    def spend(self, client: str, shared: Shared | None = None) -> int:
        """Spend one failure of ``client``: 0 if it had one left, else the wait [s] (>= 1)."""
        period = 1.0 / self.refill_per_s
        tolerance = (self.burst - 1) * period
        now = self.clock()
        with self._lock:
            start = max(self._tat.pop(client, now), now)
            self._tat[client] = start  # most recent last
            while len(self._tat) > MAX_CLIENTS:
                self._tat.popitem(last=False)
        if start - now > tolerance:
            return max(1, math.ceil(start - tolerance - now))
        refused = None if shared is None else shared(client, now, period, tolerance)
        with self._lock:
            if refused is None:  # allowed: at least this late now
                self._tat[client] = max(self._tat.get(client, now), start + period)
                return 0
            self._tat[client] = max(self._tat.get(client, now), refused)
        return max(1, math.ceil(max(refused, now) - tolerance - now))


@dataclass
class _Window:
    start_s: float
    count: int  # failures this process counted in the window
    written: int  # of which added to the shared count
    written_at_s: float


#: ``add(client, action, reason, start_s, window_s, delta)``: add ``delta`` failures to the
#: count every instance shares for that window and write its audit row
#: (:func:`db.audit_windows.add`).
Add = Callable[[str, str, str, float, float, int], object]


class FailureLog:
    """One audit row per (client, action, reason) and window, its ``count`` kept up to date.

    The count is the database's, summed over every instance (:mod:`db.audit_windows`; before
    issue 33 each worker had its own row). Each process counts in memory and adds what it
    counted: at its first failure of a window at once (the row appears with the failure),
    then at most every ``flush_s`` seconds, and when the next window of the same client
    starts. Counts still in memory are added by :meth:`flush`, which the service calls every
    ``flush_s`` seconds and when it shuts down (:mod:`api.rest.lifespan`): the end of a burst
    is counted even when no failure follows it. A process that is killed loses at most
    ``flush_s`` seconds of its counts. A failed add leaves the count pending.

    Parameters
    ----------
    window_s : float
        Length of a window [s].
    flush_s : float
        Shortest time between two adds of one window by this process [s].
    clock : callable
        Wall-clock time [s]: every instance must read the same (a test passes its own).
    """

    def __init__(
        self,
        window_s: float = WINDOW_S,
        flush_s: float = FLUSH_S,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.window_s, self.flush_s, self.clock = window_s, flush_s, clock
        self._windows: OrderedDict[tuple[str, str, str], _Window] = OrderedDict()
        self._lock = threading.Lock()

    def record(self, client: str, action: str, reason: str, add: Add) -> None:
        """Count one failure, adding the pending count to the shared one when it is due."""
        with self._lock:  # the database calls too: one failure's row at a time
            now = self.clock()
            start = math.floor(now / self.window_s) * self.window_s
            key = (client, action, reason)
            window = self._windows.pop(key, None)
            if window is not None and window.start_s != start:
                self._add(key, window, add, now)  # the old window's last count
                window = None
            if window is None:
                window = _Window(start, 0, 0, now - self.flush_s)
            window.count += 1
            self._windows[key] = window
            while len(self._windows) > MAX_CLIENTS:
                self._windows.popitem(last=False)
            if now - window.written_at_s >= self.flush_s:
                self._add(key, window, add, now)

    def flush(self, add: Add) -> int:
        """Add every count not yet shared; returns how many windows were written.

        An error of ``add`` propagates; the counts not added stay pending.
        """
        with self._lock:  # a request's write keeps its own period (``written_at_s``)
            pending = [(k, w) for k, w in self._windows.items() if w.count > w.written]
            for key, window in pending:
                self._add(key, window, add)
            return len(pending)

    def _add(
        self, key: tuple[str, str, str], window: _Window, add: Add, now: float | None = None
    ) -> None:
        """Add the window's pending count; a request's add (``now``) restarts its period."""
        if window.count > window.written:
            add(*key, window.start_s, self.window_s, window.count - window.written)
            window.written = window.count
            if now is not None:
                window.written_at_s = now
