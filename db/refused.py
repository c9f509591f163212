"""What this version refuses of a plan stored under an earlier one, and the replan that repairs it.

A release that tightens a check (``z`` at least 1 since migration 0025; a limit's or a bound's
range) leaves stored plans that fail it. Such a plan must lock no one out: its reports are
refused naming the value and the repair (:class:`~db.errors.StoredSettingsError`,
:class:`~db.errors.StoredPlanError`, 409 over REST), and the replan that sets the value anew
reads the plan with its changes applied (:func:`repaired`), where reading the stored plan first
would refuse the repair itself.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from sqlalchemy.orm import Session

from db.errors import ConflictError, StoredPlanError
from db.plan_state import plan_settings
from db.plans import PlanRow, current_body, plan_tools
from models.errors import InputError
from supervisor.inputs.plan import Plan, plan_from_mapping
from supervisor.rcb.settings import settings_from_table
from supervisor.rcb.state import RcbSettings

#: A field of an operation's limits or bounds, which a replan changes (``--limit``, ``--bound``).
_REPLANNED = re.compile(r"operations\[(\d+)\]\.(limits|bounds)\.(\w+)")


def stored_plan(*, session: Session, plan_row: PlanRow) -> Plan:
    """The plan in force as stored; :class:`~db.errors.StoredPlanError` when it fails the check."""
    body = current_body(session=session, plan_row=plan_row)
    try:
        return plan_from_mapping(body, plan_tools(session=session, plan_id=plan_row.id))
    except InputError as err:
        raise _refused(plan_row, body, err) from None


def plan_refused(*, session: Session, plan_row: PlanRow) -> str | None:
    """Why this version refuses a plan's stored structure or a stored tool it uses, if it does.

    The message names the repair (None: nothing refused); one plan's check, for its own page.
    """
    try:
        stored_plan(session=session, plan_row=plan_row)
    except ConflictError as err:  # StoredPlanError, or a stored tool refused (db.library)
        return str(err)
    return None


def repaired(
    *, session: Session, plan_row: PlanRow, changes: Mapping[str, Any]
) -> tuple[RcbSettings, Plan]:
    """The settings and the plan as a replan's ``changes`` leave them (checked as it does).

    A stored value the changes do not set anew is refused as stored (naming the repair); a
    changed value that fails is refused as the replan names it.
    """
    from supervisor.rcb.replan import changed_body  # the optimizer's: not for a plan's page

    settings = plan_settings(plan_row, rcb_given(changes))
    body = current_body(session=session, plan_row=plan_row)
    tools = plan_tools(session=session, plan_id=plan_row.id)
    try:
        return settings, plan_from_mapping(changed_body(body, changes), tools)
    except InputError as err:
        try:
            plan_from_mapping(body, tools)
        except InputError as before:
            if (before.field, before.value) == (err.field, err.value):  # not set anew
                raise _refused(plan_row, body, before) from None
        raise


def rcb_given(changes: Mapping[str, Any]) -> dict[str, object] | None:
    """The RCB settings a replan's changes give, checked (None: none)."""
    table = changes.get("rcb") if isinstance(changes, Mapping) else None
    return settings_from_table(table) if isinstance(table, Mapping) and table else None


def _refused(plan_row: PlanRow, body: Mapping[str, Any], err: InputError) -> StoredPlanError:
    """The stored plan's error, naming the plan and how to set the value anew."""
    found = _REPLANNED.match(err.field)
    where = f"POST /plans/{plan_row.id}/replan"
    if found is None:
        repair = (
            f"a replan cannot change {err.field}: create the plan anew from its file with "
            f"it changed (rcb plans create FILE, under another name)"
        )
    else:
        index, kind, name = int(found[1]), found[2], found[3]
        operation = body["operations"][index].get("name", f"operations[{index}]")
        key = f"{operation}.{name}"
        option, value, given = (
            ("--limit", "VALUE", "VALUE") if kind == "limits" else ("--bound", "LO:HI", "[LO, HI]")
        )
        repair = (
            f"set it anew: rcb replan {plan_row.id} {option} {key}={value} "
            f'({where} {{"{kind}": {{"{key}": {given}}}}})'
        )
    return StoredPlanError(plan_row.id, plan_row.name, err.field, err.value, err.reason, repair)
