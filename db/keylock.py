"""Which idempotency keys are in flight, on SQLite: byte-range locks on a file beside the database.

On SQLite every writer waits for ``BEGIN IMMEDIATE``, so a retry of a request that is still
running would only queue behind it. The IETF Idempotency-Key draft asks for 409 instead. A
request holds an exclusive POSIX lock on one byte of ``<database>-keys.lock`` (the byte at the
key's hash) for as long as it runs; a second request for the same key finds the byte locked.
The kernel drops a process's locks when it dies (``kill -9`` included), so a crashed request
never leaves its key stuck. POSIX locks belong to a process, not a thread, so threads of one
server process also check an in-process set. PostgreSQL uses advisory locks instead
(:func:`db.idempotency.claim_key`).
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from sqlalchemy import Engine


class _KeyLocks:
    def __init__(self, path: str | None) -> None:
        self._fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600) if path else None
        self._held: set[int] = set()
        self._mutex = threading.Lock()

    def try_acquire(self, offset: int) -> bool:
        with self._mutex:
            if offset in self._held:
                return False
            if self._fd is not None:
                try:
                    fcntl.lockf(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB, 1, offset, os.SEEK_SET)
                except OSError:
                    return False
            self._held.add(offset)
            return True

    def release(self, offset: int) -> None:
        with self._mutex:
            if self._fd is not None:
                fcntl.lockf(self._fd, fcntl.LOCK_UN, 1, offset, os.SEEK_SET)
            self._held.discard(offset)


_registry: dict[str, _KeyLocks] = {}
_registry_mutex = threading.Lock()


def _locks(engine: Engine) -> _KeyLocks:
    database = engine.url.database or ""
    path = None if database in ("", ":memory:") else os.path.abspath(database) + "-keys.lock"
    with _registry_mutex:
        if (path or "") not in _registry:
            _registry[path or ""] = _KeyLocks(path)
        return _registry[path or ""]


@contextmanager
def in_flight(engine: Engine, scope: str) -> Iterator[bool]:
    """Hold ``scope`` for the duration; yields False if another request holds it.

    Only SQLite engines are guarded here; for other databases it yields True.
    """
    if engine.dialect.name != "sqlite":
        yield True
        return
    locks = _locks(engine)
    offset = int(hashlib.sha256(scope.encode()).hexdigest()[:15], 16)
    if not locks.try_acquire(offset):
        yield False
        return
    try:
        yield True
    finally:
        locks.release(offset)
