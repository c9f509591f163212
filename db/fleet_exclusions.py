"""An engineer takes a plan or a machine out of the fleet, and puts it back (``rcb fleet``).

Excluded, a plan's (or every plan of a machine's) learned models no longer make any new
plan's prior (:func:`db.fleet.fleet_evidence`); a plan whose process changed is out by
itself until an engineer puts it back, accepting the changes it counted so far. Putting back
what is not out (a plan never excluded and with no change to accept, a machine never
excluded) changes nothing, and says so (:attr:`Included.put_back`).
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session

from db import tables as t
from db.errors import StoredSettingsError
from db.fleet_changes import clear_fleet_change, plan_changes
from db.fleet_imported import abroad, imported_machine
from db.plan_state import plan_settings
from db.plans import get_plan_row
from models.errors import InputError

#: The longest reason an exclusion keeps [characters]: a sentence or two, on every surface.
MAX_REASON = 500


class OneOfError(InputError):
    """Both or neither of two options given: ``--plan/--machine: name exactly one ...``.

    There is no one value to echo, so the message is the options and what to do.
    """

    def __init__(self, field: str, reason: str) -> None:
        super().__init__(field, None, reason)
        self.args = (f"{field}: {reason}",)


@dataclass(frozen=True)
class Included:
    """What ``rcb fleet include`` did.

    ``put_back``: something was out and is back (False: nothing to put back, nothing
    changed). ``changes_accepted``: the plan's changes of its process this include accepted,
    those counted since the last were (0 for a machine, or where none was put back).
    ``still_out``: why the plan stays out all the same ("" if nothing keeps it: its machine
    is taken out, it is halted); of a machine, its plans taken out on their own.
    """

    put_back: bool
    changes_accepted: int
    still_out: str


def exclude(
    *, session: Session, plan_id: int | None, machine: str | None, reason: str, actor: str
) -> str | None:
    """Take ``plan_id`` or ``machine`` (one of them) out of the fleet; the earlier exclusion.

    ``reason`` is kept with the exclusion and shown wherever it is: it must say something, in
    at most :data:`MAX_REASON` characters. Excluding what is already out changes nothing but
    the reason shown, and returns the one it replaces (``taken out by cli:ann: chipped``;
    None if it was not out), so the answer can say so. A plan whose strategy learns no
    posterior is never in the fleet: it is refused naming ``--plan``, as :func:`include`
    refuses it.
    """
    one_of(plan_id, machine)
    text = checked_reason(reason)
    if machine is not None:
        _known_machine(session, machine)
    if plan_id is not None:
        _learning(get_plan_row(session=session, plan_id=plan_id), plan_id)
    same = (
        t.FleetExclusion.plan_id == plan_id
        if machine is None
        else t.FleetExclusion.machine == machine
    )
    was = session.execute(select(t.FleetExclusion.actor, t.FleetExclusion.reason).where(same))
    earlier = [f"taken out by {by}: {why}" for by, why in was]
    session.execute(delete(t.FleetExclusion).where(same))
    session.add(t.FleetExclusion(plan_id=plan_id, machine=machine, reason=text, actor=actor))
    return earlier[0] if earlier else None


def checked_reason(reason: object, field: str = "--reason") -> str:
    """``reason`` stripped: 1 to :data:`MAX_REASON` printable characters, else an error.

    ``reason`` as sent: a JSON body's may be any value, refused unless text.
    """
    if not isinstance(reason, str):
        raise InputError(field, reason, f"give why as text, in 1 to {MAX_REASON} characters")
    text = reason.strip()
    if not text or len(text) > MAX_REASON:
        raise InputError(field, reason, f"give why, in 1 to {MAX_REASON} characters")
    if not text.isprintable():  # it is shown on terminals (rcb fleet show): an escape recolours
        raise InputError(field, reason, "one line, no control or invisible characters")
    return text


def include(
    *, session: Session, plan_id: int | None, machine: str | None, changes: int | None = None
) -> Included:
    """Put ``plan_id`` or ``machine`` back; a plan's changes so far are accepted.

    ``changes``: how many changes of its process not accepted the engineer saw (``rcb fleet
    show``: ``2 not accepted``); given, the plan is put back only if it has that many still,
    so a change counted after the engineer looked is not accepted unseen (None: accept all).

    Raises :class:`~models.errors.InputError` naming ``--machine`` or ``--plan`` for a machine
    no stored plan or imported model is of, a plan not stored, or a plan whose strategy
    learns no posterior (never in the fleet); naming ``--changes`` for a count given with a
    machine, below 0, or not the plan's. What is not out is left as it is.
    """
    one_of(plan_id, machine)
    _changes_asked(changes, machine)
    if machine is not None:
        _known_machine(session, machine)
        gone = session.execute(delete(t.FleetExclusion).where(t.FleetExclusion.machine == machine))
        return Included(bool(getattr(gone, "rowcount", 0)), 0, _plans_out(session, machine))
    row = _learning(get_plan_row(session=session, plan_id=plan_id or 0, lock=True), plan_id)
    counted = plan_changes(session=session, plan_ids=[row.id])[row.id]
    unaccepted = max(counted - row.fleet_changes_accepted, 0)
    if changes is not None and changes != unaccepted:
        raise InputError("--changes", changes, _not_seen(row.id, unaccepted))
    gone = session.execute(delete(t.FleetExclusion).where(t.FleetExclusion.plan_id == row.id))
    changed = unaccepted > 0 or row.fleet_change_part is not None
    still = _still_out(session, row)
    if not (getattr(gone, "rowcount", 0) or changed):
        return Included(False, 0, still)
    row.fleet_changes_accepted = counted
    clear_fleet_change(row)
    return Included(True, unaccepted, still)  # what it accepted, not the running total


def _changes_asked(changes: int | None, machine: str | None) -> None:
    """Refuse ``--changes`` with a machine (it has none of its own) or below 0."""
    if changes is None:
        return
    if machine is not None:
        raise InputError("--changes", changes, "a plan's count: give it with --plan, not --machine")
    if changes < 0:
        raise InputError("--changes", changes, "a count of changes, 0 or more")


def _not_seen(plan_id: int, unaccepted: int) -> str:
    """Why ``--changes`` is refused: the plan's count now, and where to review it."""
    has = f"{unaccepted} change{'' if unaccepted == 1 else 's'}"
    return (
        f"plan {plan_id} has {has} of its process not accepted now: nothing put back "
        f"(where they were counted: rcb plans show {plan_id})"
    )


def kept_reason(reason: object) -> dict[str, str]:
    """What a refused write's audit entry keeps of an engineer's reason.

    ``{"reason": text}`` where it passes :func:`checked_reason`, else nothing: a refused
    reason is named, as sent, by the refusal itself; none given is none kept.
    """
    try:
        return {"reason": checked_reason(reason)}
    except InputError:
        return {}


def one_of(plan: object, machine: object) -> None:
    """Refuse both or neither of ``--plan`` and ``--machine`` (:class:`OneOfError`)."""
    if plan is not None and machine is not None:
        raise OneOfError("--plan/--machine", "name exactly one of a plan and a machine, not both")
    if plan is None and machine is None:
        raise OneOfError("--plan/--machine", "name exactly one of a plan and a machine, not none")


def _known_machine(session: Session, machine: str) -> None:
    """Refuse a machine no stored plan or imported model is of (names compare exactly)."""
    if session.scalar(select(t.Machine.id).where(t.Machine.name == machine)) is not None:
        return
    if imported_machine(session=session, name=machine):
        return
    reason = "no stored plan or imported model is of this machine"
    alike = select(t.Machine.name).where(func.lower(t.Machine.name) == machine.lower())
    close = session.scalar(alike.order_by(t.Machine.name).limit(1))
    if close is not None:  # names compare exactly: LATHE-B is not lathe-b
        reason += f" (names are exact: {close}?)"
    m = t.ImportedModel
    found = session.execute(
        select(m.machine, m.origin).where(m.machine == machine).order_by(m.origin).limit(1)
    ).first()
    if close is None and found is not None:  # another plant's machine of this name
        reason += f" here; imported machines are named NAME@ORIGIN: {abroad(*found)}?"
    raise InputError("--machine", machine, reason)


def _learning(row: t.Plan | None, plan_id: int | None) -> t.Plan:
    """``row``, a stored plan that learns; else an error naming ``--plan``."""
    if row is None:
        raise InputError("--plan", plan_id, "no such plan")
    strategy = _strategy(row)
    if strategy != "learn":
        raise InputError(
            "--plan", plan_id, f"strategy {strategy} learns no posterior: never in the fleet"
        )
    return row


def _strategy(row: t.Plan) -> str:
    """The plan's strategy; a stored setting this version refuses leaves it as stored."""
    try:
        return plan_settings(row).strategy
    except StoredSettingsError:
        return str((row.settings or {}).get("strategy") or "learn")


#: The most plan ids :func:`_plans_out` names (a line, not a list: ``rcb fleet show`` has all).
NAMED_PLANS = 5


def _plans_out(session: Session, machine: str) -> str:
    """The plans of ``machine`` taken out on their own, which stay out ("" none)."""
    e = t.FleetExclusion
    ids = session.scalars(
        select(e.plan_id)
        .join(t.Plan, t.Plan.id == e.plan_id)
        .join(t.Machine, t.Machine.id == t.Plan.machine_id)
        .where(t.Machine.name == machine)
        .order_by(e.plan_id)
        .limit(NAMED_PLANS + 1)
    ).all()
    if not ids:
        return ""
    more = ", ..." if len(ids) > NAMED_PLANS else ""
    named = ", ".join(str(i) for i in ids[:NAMED_PLANS]) + more
    if len(ids) == 1:  # the command whole, to copy
        return f"its plan {named} is taken out on its own (rcb fleet include --plan {named})"
    return f"its plans {named} are taken out on their own (rcb fleet include --plan ID)"


def _still_out(session: Session, row: t.Plan) -> str:
    """What keeps the plan out besides its own exclusion and its changes ("" nothing)."""
    machine = session.scalar(select(t.Machine.name).where(t.Machine.id == row.machine_id))
    found = select(t.FleetExclusion.id).where(t.FleetExclusion.machine == machine).limit(1)
    if machine is not None and session.scalar(found) is not None:
        return f"its machine {machine} is taken out (rcb fleet include --machine {machine})"
    if row.halt is not None:
        return f"it is halted: a replan resumes it (rcb replan {row.id})"
    return ""
