"""Idempotency-Key records of the writes (IETF draft "The Idempotency-Key HTTP Header Field").

A write given a key stores its answer under the key in its own transaction
(:func:`api.services.transactions.write`); a retry with the same request gets the stored
answer back (:func:`replay_of`), the same key with another request is refused
(:class:`KeyReuseError`), and a key whose request still runs is in flight (:class:`InFlightError`).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

from db.intake import StoredAnswer


class InFlightError(Exception):
    """A request with this Idempotency-Key is still being processed."""

    def __init__(self, key: str) -> None:
        self.field, self.value = "Idempotency-Key", key
        super().__init__(f"Idempotency-Key = {key!r}: a request with this key is in flight")


class KeyReuseError(Exception):
    """An Idempotency-Key already used for a different request."""

    def __init__(self, key: str) -> None:
        self.field, self.value = "Idempotency-Key", key
        super().__init__(
            f"Idempotency-Key = {key!r}: already used for a different request; use a new key"
        )


@dataclass(frozen=True)
class Idempotency:
    """An Idempotency-Key and the fingerprint of the request it was sent with."""

    key: str
    request_hash: str


def fingerprint(method: str, path: str, body: object) -> str:
    """SHA-256 of the method, path and canonical JSON of the body.

    Taken before the body is read (a plan's reader refuses a lone surrogate later): such a
    string is hashed as its code units (``surrogatepass``), every valid text as UTF-8.
    """
    canonical = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(
        f"{method} {path}\n{canonical}".encode("utf-8", "surrogatepass")
    ).hexdigest()


@dataclass(frozen=True)
class Written:
    """The response of a write: status, body, and whether it is a stored replay.

    ``text``: the body's JSON as stored with the idempotency key (a new answer's, encoded
    once for the database and the HTTP answer); None for a replay.
    """

    status: int
    body: dict[str, Any]
    replayed: bool = False
    text: str | None = None


def replay_of(stored: StoredAnswer | None, idempotency: Idempotency) -> Written | None:
    """The answer stored under the key, as a replay (None if none); another request's: 422."""
    if stored is None:
        return None
    if stored.request_hash != idempotency.request_hash:
        raise KeyReuseError(idempotency.key)
    return Written(stored.status, dict(stored.body or {}), True)
