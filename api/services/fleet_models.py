"""The use cases of ``rcb models export`` and ``import`` (:mod:`db.fleet_models`)."""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services.idempotency import Written
from api.services.transactions import audited, transaction, write
from db import api_keys
from db.api_keys import Actor
from db.fleet_exclusions import checked_reason, exclude, include, kept_reason
from db.fleet_models import export_models, import_models
from db.identity import database_id, inherited, renew


def export_tool(*, engine: Engine, tool: str, material: str | None = None) -> dict[str, Any]:
    """The document of ``tool``'s learned models (a read)."""
    with Session(engine) as session, session.begin():
        return export_models(session=session, tool=tool, material=material)


def import_tool(
    *, engine: Engine, data: object, source: str, actor: Actor = api_keys.CLI_ACTOR
) -> Written:
    """Store a document's learned models, all or none (audited, with what it did).

    The audit entry's detail holds the counts the answer reports (``stored``, ``new``,
    ``replaced``, ``kept``, ``own``, ``copied``), so ``rcb audit`` says what an import did.
    """
    counts: dict[str, Any] = {}  # the entry's detail, filled in by the work before it is written
    with audited(engine, actor, "import models", source):

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            done = import_models(session=session, data=data, source=source).to_json()
            counts.clear()
            counts.update(done)
            return 201, {**done, "source": source}

        return write(
            engine,
            actor=actor,
            action="import models",
            target=source,
            idempotency=None,
            work=work,
            detail=counts,
        )


def identity(*, engine: Engine) -> dict[str, Any]:
    """The database's identity and the plans it holds from another's, counted by origin."""
    with Session(engine) as session, session.begin():
        return {"identity": database_id(session=session), "inherited": inherited(session=session)}


def renew_identity(*, engine: Engine, actor: Actor = api_keys.CLI_ACTOR) -> Written:
    """Give a copied database an identity of its own; its plans keep the old (audited)."""
    with audited(engine, actor, "renew identity", "database"):

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            old, new, kept = renew(session=session)
            return 200, {"identity": new, "was": old, "plans_keeping_it": kept}

        return write(
            engine,
            actor=actor,
            action="renew identity",
            target="database",
            idempotency=None,
            work=work,
        )


def exclude_from_fleet(
    *,
    engine: Engine,
    plan_id: int | None,
    machine: str | None,
    reason: str,
    actor: Actor = api_keys.CLI_ACTOR,
) -> Written:
    """Take a plan or a machine out of the fleet (audited, refused too: with the reason).

    ``was``: the exclusion this one replaces (``taken out by cli:ann: chipped``), None if what
    is named was not out: excluding it again changes the reason alone.
    """
    target = fleet_target(plan_id, machine)
    plan = plan_id if machine is None else None
    with audited(engine, actor, "fleet exclude", target, plan_id=plan, kept=kept_reason(reason)):

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            was = exclude(
                session=session, plan_id=plan_id, machine=machine, reason=reason, actor=actor.name
            )
            return 200, {"excluded": target, "reason": reason.strip(), "was": was}

        return write(
            engine,
            actor=actor,
            action="fleet exclude",
            target=target,
            idempotency=None,
            work=work,
            detail={"reason": reason.strip()},
            plan=plan,
        )


def include_in_fleet(
    *,
    engine: Engine,
    plan_id: int | None,
    machine: str | None,
    changes: int | None = None,
    reason: str | None = None,
    actor: Actor = api_keys.CLI_ACTOR,
) -> Written:
    """Put a plan or a machine back in the fleet; a plan's changes so far accepted.

    ``changes``: the count of changes not accepted the engineer reviewed; the plan must still
    have that many (:func:`db.fleet_exclusions.include`). ``reason``: why, kept in the audit
    entry (optional). Audited when something was put back, with what it accepted and what
    still keeps the plan out, or refused (with the reason, once checked); putting back what
    is not out changes nothing and writes no audit entry (``put_back`` false, ``still_out``:
    why the plan stays out all the same, "" if nothing keeps it).
    """
    target = fleet_target(plan_id, machine)
    plan = plan_id if machine is None else None
    detail: dict[str, Any] = {}  # the entry's, filled in before the answer writes it
    with (
        audited(engine, actor, "fleet include", target, plan_id=plan, kept=kept_reason(reason)),
        transaction(engine, actor, "fleet include", target, None, detail=detail, plan=plan) as tx,
    ):
        why = None if reason is None else checked_reason(reason)
        done = include(session=tx.session, plan_id=plan_id, machine=machine, changes=changes)
        body = {
            "included": target,
            "put_back": done.put_back,
            "changes_accepted": done.changes_accepted,
            "still_out": done.still_out,
        }
        if not done.put_back:  # nothing changed: no entry in the audit log
            return Written(200, body)
        detail.update({"reason": why, **{k: body[k] for k in ("changes_accepted", "still_out")}})
        return tx.answer(200, body)


def fleet_target(plan_id: int | None, machine: str | None) -> str:
    """The audit target of an exclusion or inclusion: ``plan 3``, ``machine lathe-b``.

    Both or neither (refused): what was named, so the log says what was asked.
    """
    named = [f"plan {plan_id}"] if plan_id is not None else []
    named += [f"machine {machine}"] if machine is not None else []
    return " and ".join(named) or "neither a plan nor a machine"
