"""A plan's RCB settings and its halt, as the JSON of ``plans.settings`` and ``plans.halt``.

``plans.settings`` holds every setting of :class:`supervisor.rcb.state.RcbSettings` by the name
:data:`supervisor.rcb.settings.SETTINGS` declares (NULL, or a key missing: the default).
``plans.halt`` holds the conflicts of a halted plan in the form the REST
answers show them (``message`` and, per operation, ``operation``, ``message``,
``conflicts`` and ``held_by``; a halt on a reading past its limit by more than ``halt_over`` has
no conflicts and nothing holding it: its ``message`` says which reading).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol

from db.errors import StoredSettingsError
from models.errors import InputError
from supervisor.errors import Conflict
from supervisor.rcb.settings import SETTINGS
from supervisor.rcb.settings import settings_json as settings_json
from supervisor.rcb.state import Halt, HaltedOperation, RcbSettings


def settings_of(stored: Mapping[str, Any] | None) -> RcbSettings:
    """The :class:`RcbSettings` of a plan's ``settings`` column."""
    given = _given(stored)
    if "floors" in given:
        given["floors"] = {str(q): float(v) for q, v in given["floors"].items()}
    return RcbSettings(**given)


class _Plan(Protocol):
    id: int
    name: str
    settings: dict[str, Any] | None


def plan_settings(row: _Plan, over: Mapping[str, Any] | None = None) -> RcbSettings:
    """A plan's settings as stored, with ``over`` (settings a replan gives, checked) over them.

    Raises
    ------
    StoredSettingsError
        A stored value (not one of ``over``) fails this version's check: names the plan, the
        setting and how to set it anew.
    """
    given = {**_given(row.settings), **(over or {})}
    try:
        return settings_of(given)
    except InputError as err:  # err.field: alpha, floors.force_N ...
        if over and err.field.partition(".")[0] in over:
            raise
        raise StoredSettingsError(row.id, row.name, err.field, err.value, err.reason) from None


def settings_shown(stored: Mapping[str, Any] | None) -> dict[str, Any]:
    """A plan's ``settings`` column as a list shows it: checked, or else as stored.

    A stored value that fails this version's check (one tightened since it was stored) would
    otherwise keep every plan from the list: the stored values are shown over the defaults as
    they are, and the surfaces that use the settings say which value fails.
    """
    try:
        return settings_json(settings_of(stored))
    except InputError:
        return _as_stored(stored)


def settings_listed(row: _Plan) -> tuple[dict[str, Any], str | None]:
    """A plan's settings as :func:`settings_shown` shows them, and why this version refuses them.

    The reason names the repair (None: nothing refused); the stored column is read once.
    """
    try:
        return settings_json(plan_settings(row)), None
    except StoredSettingsError as err:
        return _as_stored(row.settings), str(err)


def _as_stored(stored: Mapping[str, Any] | None) -> dict[str, Any]:
    """The stored settings over the defaults, unchecked (a value this version refuses too)."""
    return {**settings_json(RcbSettings()), **_given(stored)}


def _given(stored: Mapping[str, Any] | None) -> dict[str, Any]:
    """The settings a ``settings`` column holds (NULL, a key missing or unknown: none)."""
    return {k: v for k, v in (stored or {}).items() if k in SETTINGS and v is not None}


def halt_json(halt: Halt) -> dict[str, Any]:
    """``plans.halt`` of ``halt``: its message and the conflicts per halted operation."""
    return {
        "message": halt.message,
        "conflicts": [
            {
                "operation": o.operation,
                "message": o.message,
                "conflicts": [
                    {"name": c.name, "limit": c.limit, "required": c.required, "sense": c.sense}
                    for c in o.conflicts
                ],
                "held_by": list(o.against),
            }
            for o in halt.operations
        ],
    }


def halt_of(stored: Mapping[str, Any] | None) -> Halt | None:
    """The :class:`Halt` of ``plans.halt`` (None: the plan runs)."""
    if not stored:
        return None
    return Halt(
        tuple(
            HaltedOperation(
                operation=o["operation"],
                conflicts=tuple(
                    Conflict(c["name"], float(c["limit"]), float(c["required"]), c["sense"])
                    for c in o["conflicts"]
                ),
                against=tuple(o["held_by"]),
                message=o["message"],
            )
            for o in stored["conflicts"]
        )
    )
