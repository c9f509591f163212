"""Use cases that write a plan: create (check, optimise, store version 1) and replan.

Each is one transaction (:func:`api.services.transactions.write`), idempotent when given an
Idempotency-Key, and audited, refused or not.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from contextlib import nullcontext, suppress
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import to_json
from api.services.errors import NotFoundError
from api.services.idempotency import Idempotency, Written
from api.services.read.common import PLAN_ID
from api.services.transactions import Work, audited, write
from db import api_keys, library
from db.api_keys import Actor
from db.fleet import plan_priors, prior_answer, prior_json
from db.fleet_exclusions import checked_reason, kept_reason
from db.fleet_members import plan_out
from db.fleet_noise import noise_prior_json
from db.intake import stored_answer
from db.plans import (
    add_plan,
    add_replan,
    current_body,
    get_plan_row,
    plan_tools,
    refuse_taken,
)
from db.state import load_state
from models.errors import Gathered, InputError
from models.fields import identity
from supervisor.inputs.plan import Plan, plan_from_mapping
from supervisor.rcb.replan import replan as supervisor_replan
from supervisor.rcb.settings import SETTINGS
from supervisor.rcb.state import RcbSettings, RcbState, plan_settings
from supervisor.rcb.strategies import REGISTRY
from supervisor.rcb.update import start


def floors_from(items: Sequence[str], field: str) -> dict[str, float]:
    """Floors given as ``QUANTITY=VALUE`` (the query parameter ``floor``), checked.

    An error names ``field`` and the text as sent (``floor = 'force_N=-5'``), not the setting's
    own name (``floors.force_N``), which the request does not have.
    """
    floors: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        quantity = name.strip()
        if not sep or not quantity:
            raise InputError(field, item, "must be QUANTITY=VALUE")
        if quantity in floors:
            raise InputError(field, item, f"{quantity} is given twice; give each floor once")
        try:
            number = float(value)
            SETTINGS["floors"].check({quantity: number}, field)
        except InputError as err:  # an InputError is a ValueError: first
            raise InputError(field, item, f"{quantity}: {err.reason}") from None
        except ValueError:
            raise InputError(field, item, "the value must be a number") from None
        floors[quantity] = number
    return floors


def create_plan(
    *,
    engine: Engine,
    body: Mapping[str, Any],
    settings: RcbSettings | None = None,
    actor: Actor = api_keys.CLI_ACTOR,
    idempotency: Idempotency | None = None,
    prior: str | None = None,
    given: Mapping[str, object] | None = None,
) -> Written:
    """Check and optimise a plan, store it with setpoint version 1 (status 201).

    ``settings``: the plan's RCB law, every setting stored (default: the body's ``rcb`` table
    with ``given`` over it, :func:`supervisor.rcb.state.plan_settings`; its errors and the
    plan's are refused together). ``prior``: ``fleet`` (what the stored plans learned with its
    tools, :mod:`db.fleet`), ``catalogue``, or None: the fleet's where the database holds
    evidence for a ``learn`` plan's tools, else the catalogue's.
    """
    with audited(engine, actor, "create plan", f"plan {body.get('name', '')}"):
        with Session(engine) as session:
            settings, plan = _read(session, body, settings, given)
            if idempotency is None or stored_answer(session, actor.id, idempotency.key) is None:
                refuse_taken(session, plan.name)  # before the prior: a retry's key replays
            priors, noise = plan_priors(session=session, plan=plan, settings=settings, prior=prior)
        # outside the write transaction: it needs no lock
        result = start(plan, settings, {k: p.posterior for k, p in priors.items()}).setpoints
        stored_prior, stored_noise = prior_json(priors), noise_prior_json(noise)

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            plan_id = add_plan(
                session=session,
                body=body,
                plan=plan,
                result=result,
                settings=settings,
                prior=stored_prior,
                noise_prior=stored_noise,
            )
            return 201, {
                "id": plan_id,
                "name": plan.name,
                "setpoint_version": 1,
                "cycle_time_min": result.cycle_time_min,
                **prior_answer(stored_prior, stored_noise),
                "fleet_out": _taken_out(session, plan_id, plan, settings),
                **operations_json(result),
            }

        return write(
            engine,
            actor=actor,
            action="create plan",
            target=f"plan {plan.name}",
            idempotency=idempotency,
            work=work,
            attempts=3,
            detail=_created(plan, settings, stored_prior),
            plan="id",  # the new plan's, in the answer
        )


def _created(plan: Plan, settings: RcbSettings, prior: object) -> dict[str, Any]:
    """What the audit log says of a new plan: its machine, its strategy and its start."""
    start_from = "fleet" if prior else "catalogue"
    return {"machine": plan.machine.name, "strategy": settings.strategy, "prior": start_from}


def _read(
    session: Session,
    body: Mapping[str, Any],
    settings: RcbSettings | None,
    given: Mapping[str, object] | None,
) -> tuple[RcbSettings, Plan]:
    """The settings and the plan, their errors refused together (the ``[rcb]`` table's first)."""
    found = Gathered()
    chosen = settings or found.read(plan_settings, body, given)
    plan = found.read(plan_from_mapping, body, named_tools(session, body))
    found.raise_any()
    assert chosen is not None and plan is not None
    if PLAN_ID.fullmatch(plan.name.strip()):
        raise InputError("name", plan.name, "must not be only digits (PLAN digits: an id)")
    return chosen, plan


def _taken_out(session: Session, plan_id: int, plan: Plan, settings: RcbSettings) -> str | None:
    """The new plan's ``fleet_out``: what ``GET /plans/{id}`` says, where its strategy learns.

    :func:`db.fleet_members.plan_out`, which does not count having no part yet: a plan just
    stored is out only where an engineer took its machine out of the fleet (nothing has
    halted it or changed its process yet); then its readings make no new plan's prior. None
    where its strategy learns no posterior: never in the fleet, an exclusion takes nothing
    from it, and ``plan_out``'s "learns no posterior" would be said of every such plan.
    """
    if not REGISTRY[settings.strategy].learns_model:
        return None
    return plan_out(session=session, row=_plan(session, plan_id), machine=plan.machine.name)


def replan(
    *,
    engine: Engine,
    plan_id: int,
    changes: Mapping[str, Any],
    dry_run: bool = False,
    actor: Actor = api_keys.CLI_ACTOR,
    idempotency: Idempotency | None = None,
    reason: str | None = None,
) -> Written:
    """Apply an engineer's change and re-optimise; unless ``dry_run``, store it.

    The new setpoint version has cause ``replan``; the answer shows the difference to the
    setpoints in force (:mod:`supervisor.rcb.replan`). ``reason``: why, checked as a fleet
    exclusion's (refused naming ``reason``, a dry run's too) and kept in the audit entry's
    detail, ``{"reason": ...}`` (``rcb audit --plan``), a refused replan's too.
    """
    # a dry run stores nothing and is not a write: refused or not, the audit log has no entry
    # (an engineer's what-ifs read as a series of refused replans that never happened)
    kept = kept_reason(reason)
    refusals = (
        nullcontext()
        if dry_run
        else audited(engine, actor, "replan", f"plan {plan_id}", plan_id=plan_id, kept=kept)
    )
    with refusals:
        detail = _reason_detail(reason)

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            row = _plan(session, plan_id, lock=True)
            before = load_state(session=session, plan_row=row, repair=changes)
            body = current_body(session=session, plan_row=row)
            library = plan_tools(session=session, plan_id=plan_id)  # its tools, no other
            done = supervisor_replan(before, body, changes, library)
            if not dry_run:
                add_replan(
                    session=session,
                    plan_row=row,
                    body=done.body,
                    changes=dict(changes),
                    reset_bands=done.reset_bands,
                    before=before,
                    after=done.state,
                    actor=actor.name,
                )
            answer = _replan_answer(plan_id, before, done, dry_run)
            return (200 if dry_run else 201), answer

        if dry_run:
            return _rolled_back(engine, work)
        return write(
            engine,
            actor=actor,
            action="replan",
            target=f"plan {plan_id}",
            idempotency=idempotency,
            work=work,
            detail=detail,
            plan=plan_id,
        )


def _rolled_back(engine: Engine, work: Work) -> Written:
    """``work``'s answer, its transaction rolled back: a dry run stores nothing."""
    with Session(engine) as session:
        session.begin()
        try:
            status, body = work(session)
        finally:
            session.rollback()
    return Written(status, body)


def _reason_detail(reason: object) -> dict[str, Any] | None:
    """A replan's audit detail: its reason as sent, checked as an exclusion's; None without."""
    return None if reason is None else {"reason": checked_reason(reason, "reason")}


def named_tools(session: Session, body: Mapping[str, Any]) -> dict[str, Any]:
    """The stored tools a plan file's operations name, as its reader looks them up.

    Not every stored tool: a plant's library grows with the years, and a stored tool a later
    version's check refuses must refuse the plans that use it, not every new plan.
    """
    ops = body.get("operations") if isinstance(body, Mapping) else None
    names = set()
    for op in ops if isinstance(ops, list) else ():
        tool = op.get("tool") if isinstance(op, Mapping) else None
        if isinstance(tool, str):
            with suppress(ValueError):  # a name identity refuses: the reader names the field
                names.add(identity(tool))
    return library.load_tools(session=session, names=sorted(names))


def _replan_answer(plan_id: int, before: RcbState, done: Any, dry_run: bool) -> dict[str, Any]:
    old = {op.name: op for op in before.setpoints.operations}
    diff = []
    for op in done.state.setpoints.operations:
        was = old[op.name]
        diff.append(
            {
                "operation": op.name,
                "setpoint": {k: [was.setpoint.get(k), v] for k, v in op.setpoint.items()},
                "mrr_cm3_min": [was.mrr_cm3_min, op.mrr_cm3_min],
                "binding": [list(was.binding), list(op.binding)],
            }
        )
    return {
        "plan_id": plan_id,
        "dry_run": dry_run,
        "setpoint_version": before.version if dry_run else done.state.version,
        "reset_bands": done.reset_bands,
        "cycle_time_min": [before.setpoints.cycle_time_min, done.state.setpoints.cycle_time_min],
        "diff": diff,
        **operations_json(done.state.setpoints),
    }


def _plan(session: Session, plan_id: int, lock: bool = False) -> Any:
    row = get_plan_row(session=session, plan_id=plan_id, lock=lock)
    if row is None:
        raise NotFoundError("plan_id", plan_id)
    return row


def operations_json(result: Any) -> dict[str, Any]:
    """The ``operations`` of an answer: each operation's setpoint as JSON."""
    return {"operations": to_json.plan_json(result)["operations"]}
