"""Errors of the storage layer."""

from __future__ import annotations


class ConflictError(Exception):
    """The request contradicts what is stored (a duplicate serial, a tool redefined)."""

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field, self.value, self.reason = field, value, reason
        super().__init__(f"{field} = {value!r}: {reason}")
