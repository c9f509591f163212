"""An in-process cache of loaded RCB states, keyed on ``plans.state_token``.

Loading a plan's state (models in force, band states, setpoints) takes a handful of queries;
between two parts of the same plan on the same server process nothing else has changed, and
the token proves it: every write to a plan's state stores a new random token in the same
transaction, so a cached state whose token equals the stored one *is* the stored state, even
with several server processes or a database restored from a backup. A state is put in the
cache only when it is known to be committed (loaded under the plan's row lock, or after the
commit of the transaction that wrote it).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass

from sqlalchemy.orm import Session

from supervisor.rcb.state import RcbState

#: Plans whose state one process keeps.
CAPACITY = 2048


def database_key(session: Session) -> str:
    """Which database a session talks to (the cache's first key)."""
    return session.get_bind().engine.url.render_as_string(hide_password=True)


class StateCache:
    """A bounded LRU map ``(database, plan id) → (token, state, operation ids)``; thread-safe.

    The operation ids (name → ``operations.id``) of a plan never change; they are kept beside
    the state under the same token only so that a plan id reused by a restored database can
    never be answered with another plan's operations.
    """

    def __init__(self, capacity: int = CAPACITY) -> None:
        self._items: OrderedDict[tuple[str, int], _Entry] = OrderedDict()
        self._capacity = capacity
        self._lock = threading.Lock()

    def get(self, database: str, plan_id: int, token: str) -> RcbState | None:
        """The cached state if its token is ``token``."""
        entry = self._get(database, plan_id, token)
        return None if entry is None else entry.state

    def get_operations(self, database: str, plan_id: int, token: str) -> dict[str, int] | None:
        """The cached operation ids if the entry's token is ``token``."""
        entry = self._get(database, plan_id, token)
        return None if entry is None or entry.operations is None else dict(entry.operations)

    def put(
        self,
        database: str,
        plan_id: int,
        token: str,
        state: RcbState,
        operations: Mapping[str, int] | None = None,
    ) -> None:
        """Remember ``state`` (and the operation ids, if given) as the plan's at ``token``."""
        self._put(database, plan_id, token, state=state, operations=operations)

    def put_operations(
        self, database: str, plan_id: int, token: str, operations: Mapping[str, int]
    ) -> None:
        """Remember the plan's operation ids at ``token`` (its committed token)."""
        self._put(database, plan_id, token, operations=operations)

    def clear(self) -> None:
        """Forget everything."""
        with self._lock:
            self._items.clear()

    def _get(self, database: str, plan_id: int, token: str) -> _Entry | None:
        if not token:
            return None
        with self._lock:
            entry = self._items.get((database, plan_id))
            if entry is None or entry.token != token:
                return None
            self._items.move_to_end((database, plan_id))
            return entry

    def _put(
        self,
        database: str,
        plan_id: int,
        token: str,
        *,
        state: RcbState | None = None,
        operations: Mapping[str, int] | None = None,
    ) -> None:
        if not token:
            return
        with self._lock:
            entry = self._items.get((database, plan_id))
            if entry is None or entry.token != token:
                entry = _Entry(token)
            if state is not None:
                entry.state = state
            if operations is not None:
                entry.operations = dict(operations)
            self._items[(database, plan_id)] = entry
            self._items.move_to_end((database, plan_id))
            while len(self._items) > self._capacity:
                self._items.popitem(last=False)


@dataclass
class _Entry:
    token: str
    state: RcbState | None = None
    operations: dict[str, int] | None = None


CACHE = StateCache()
