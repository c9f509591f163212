"""Writes first: long reads step aside while a part report (or any write) is in flight.

A worker process serves the MES's part reports and the engineers' reads from the same
threads and the same interpreter lock. A read of a history page is about 100 ms of Python;
four viewers reading back to back left a single MES client 15-21 % of its report rate
(``benchmarks/mixed_load.py``, issue 17). Readers therefore call :meth:`WritesFirst.pause`
between pieces of their work (after a query, every few rows converted): while a write is
in flight in this process the reader waits until it is done, at most ``max_wait_s`` per
pause, so reads are slowed but never starved. Writers announce themselves with
:meth:`WritesFirst.writing` (the REST service does it for every request that is not a
read, :mod:`api.rest.writes_in_flight`). Long reads also run one at a time per process
(:meth:`WritesFirst.reading`): two readers and a writer sharing the interpreter lock left
the writer a third of it.

Per process: each uvicorn worker has its own gate; on SQLite (WAL) and PostgreSQL readers
never hold a lock a writer needs, so the gate only shares the CPU.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: Longest a reader waits at one pause [s]: reads are slowed, never starved.
MAX_WAIT_S = 0.25
#: Long reads running at once in one process; the others queue.
READERS = 1


class WritesFirst:
    """A count of writes in flight, and a pause for readers until it is zero."""

    def __init__(self, max_wait_s: float = MAX_WAIT_S) -> None:
        if not max_wait_s > 0:
            raise ValueError(f"max_wait_s = {max_wait_s!r}: must be > 0")
        self.max_wait_s = max_wait_s
        self._writes = 0
        self._idle = threading.Condition()
        self._readers = threading.BoundedSemaphore(READERS)

    @property
    def writes(self) -> int:
        """Writes in flight now."""
        return self._writes

    @contextmanager
    def writing(self) -> Iterator[None]:
        """Count a write in flight for the duration of the ``with`` block."""
        with self._idle:
            self._writes += 1
        try:
            yield
        finally:
            with self._idle:
                self._writes -= 1
                if self._writes == 0:
                    self._idle.notify_all()

    @contextmanager
    def reading(self) -> Iterator[None]:
        """A long read (a page of history): one at a time per process, after the writes."""
        with self._readers:
            self.pause()
            yield

    def pause(self) -> bool:
        """Wait while writes are in flight, at most :attr:`max_wait_s`; whether none is left."""
        if self._writes == 0:  # the common case: no lock taken
            return True
        with self._idle:
            return self._idle.wait_for(lambda: self._writes == 0, timeout=self.max_wait_s)


#: The process's gate (one per uvicorn worker).
GATE = WritesFirst()
