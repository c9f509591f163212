"""The error raised when a program or a block range cannot be rewritten safely."""

from __future__ import annotations

from models.errors import InputError
from supervisor.errors import SupervisorError


class GcodeError(SupervisorError, InputError):
    """A program or a block range that cannot be rewritten safely.

    ``field`` is ``"<program> line <n>"`` for a line of the program, ``"map"`` for a block
    range (its ``value`` is the range as given), ``"<operation>.<name>"`` for a setpoint.
    """
