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

from supervisor.rcb import RcbState

#: Plans whose state one process keeps.
CAPACITY = 2048


class StateCache:
    """A bounded LRU map ``(database, plan id) → (token, state)``; thread-safe."""

    def __init__(self, capacity: int = CAPACITY) -> None:
        self._items: OrderedDict[tuple[str, int], tuple[str, RcbState]] = OrderedDict()
        self._capacity = capacity
        self._lock = threading.Lock()

    def get(self, database: str, plan_id: int, token: str) -> RcbState | None:
        """The cached state if its token is ``token``."""
        if not token:
            return None
        with self._lock:
            item = self._items.get((database, plan_id))
            if item is None or item[0] != token:
                return None
            self._items.move_to_end((database, plan_id))
            return item[1]

    def put(self, database: str, plan_id: int, token: str, state: RcbState) -> None:
        """Remember ``state`` as the plan's state at ``token``."""
        if not token:
            return
        with self._lock:
            self._items[(database, plan_id)] = (token, state)
            self._items.move_to_end((database, plan_id))
            while len(self._items) > self._capacity:
                self._items.popitem(last=False)

    def clear(self) -> None:
        """Forget everything."""
        with self._lock:
            self._items.clear()


CACHE = StateCache()
