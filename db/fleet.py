"""What the stored plans learned with a set of tools: the fleet's evidence (issue 32).

One statement reads, for every operation that uses one of the tools in a ``learn`` plan of
each machine's newest plans with it (:mod:`db.fleet_window`), the newest band state of each of
its tool's quantities since the plan's bands were last reset (an index seek per pair on
``band_states (operation_id, quantity, part_id)``, the operations by
``ix_operations_tool_machine_plan``): the number of statements is the same for 10 plans as for
1000, and no cost grows with the plans and parts they made. The operations picked come from
one more (each read once, not once a quantity), the tools' models from one more
(:func:`db.library.load_tools`), the plans' changes of their process from one more
(:func:`db.fleet_changes.plan_changes`, summed in the database), and the models other
databases exported and this one imported from one more (``imported_models``, by
``ix_imported_models_tool``).

Left out: a plan that is halted; a plan or machine an engineer took out (``rcb fleet
exclude``, ``fleet_exclusions``); and a plan whose quantities, any of them, saw a change of
their process (a ``regime_change``: their monitors counted one) beyond those an engineer
accepted putting it back (``rcb fleet include``, ``plans.fleet_changes_accepted``). A change the
plan's readings did not confirm five parts after it (a monitor's false alarm) is accepted by
itself (:mod:`db.fleet_changes`, :mod:`supervisor.fleet.changes`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import asdict, replace
from typing import Any

from sqlalchemy import ColumnElement, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet_changes import plan_changes
from db.fleet_imported import abroad, imported_evidence
from db.fleet_left_out import left_out
from db.fleet_names import bounded, listed
from db.fleet_noise import noise_provenance
from db.fleet_states import newest_state
from db.fleet_window import newest_local
from db.let_go_mark import marked
from db.library import load_tools
from db.plan_state import settings_of
from models.errors import InputError
from supervisor.fleet.learned import Learned
from supervisor.fleet.left_out import LeftOut
from supervisor.fleet.noise import NoisePrior, noise_priors
from supervisor.fleet.prior import fleet_priors
from supervisor.fleet.provenance import FleetPrior, Provenance
from supervisor.inputs.plan import Operation, Plan
from supervisor.rcb.monitor_state import from_json as monitor_from_json
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json
from supervisor.rcb.state import RcbSettings


def fleet_evidence(*, session: Session, tool_names: Iterable[str]) -> list[Learned]:
    """Every stored ``learn`` posterior of the named tools' quantities (module docstring)."""
    names = sorted(set(tool_names))
    imported = imported_evidence(session=session, tool_names=names)
    return local_evidence(session=session, tool_names=names) + [
        replace(item, machine=abroad(item.machine, origin), plan=abroad(item.plan, origin))
        for origin, item in imported
    ]


def local_evidence(*, session: Session, tool_names: Iterable[str]) -> list[Learned]:
    """The ``learn`` posteriors of the named tools in this database's plans (module docstring).

    The plans' settings and stored priors are read once a plan (not once a model), and of the
    band states only what the fleet reads.
    """
    names = sorted(set(tool_names))
    if not names:
        return []
    tools = load_tools(session=session, names=names)
    b = t.BandState
    # each machine's newest plans, not halted nor taken out: their operations, by id
    window = newest_local(names, session.get_bind().dialect.name)
    o = t.Operation
    picked = o.id.in_(select(window.c.operation_id))
    operations = _operations(session, picked)
    rows = session.execute(
        select(
            o.id,
            o.plan_id,
            t.Plan.name,
            t.Machine.name,
            b.quantity,
            b.posterior,
            b.monitor,
            t.Plan.fleet_changes_accepted,
        )
        .join(t.ToolModel, t.ToolModel.tool_id == o.tool_id)
        .join(t.Plan, o.plan_id == t.Plan.id)
        .join(t.Machine, t.Plan.machine_id == t.Machine.id)
        .join(b, b.id == newest_state())
        .where(picked, b.posterior.is_not(None))
        .order_by(o.plan_id, o.position, b.quantity)
    ).all()
    ids = {plan_id for _, plan_id, *_ in rows}
    changes = plan_changes(session=session, plan_ids=ids)
    plans = _plans_read(session, ids)
    out = []
    for op_id, plan_id, plan, machine, quantity, posterior, monitor, accepted in rows:
        settings, started = plans[plan_id]
        if settings is None or changes.get(plan_id, 0) > accepted or op_id not in operations:
            continue
        tool, operation = operations[op_id]
        out.append(
            Learned(
                machine,
                plan,
                operation,
                tools[tool],
                posterior_from_json(posterior),
                settings.coverage_k,
                settings.exponent_sd,
                settings.edge_sd,
                started.get((operation.name, quantity)),
                None if monitor is None else monitor_from_json(monitor).chain_noise,
            )
        )
    return out


def _plans_read(
    session: Session, plan_ids: Iterable[int]
) -> dict[int, tuple[RcbSettings | None, dict[tuple[str, str], Posterior]]]:
    """Per plan, its settings and the fleet priors it started from.

    Settings None: not ``learn``, or a value this version refuses (out: ``rcb fleet show``
    says why).
    """
    ids = sorted(set(plan_ids))
    rows = session.execute(
        select(t.Plan.id, t.Plan.settings, t.Plan.prior).where(t.Plan.id.in_(ids))
    ).all()
    out: dict[int, tuple[RcbSettings | None, dict[tuple[str, str], Posterior]]] = {}
    for plan_id, stored, started in rows:
        try:
            settings: RcbSettings | None = settings_of(stored)
        except InputError:
            settings = None
        if settings is not None and settings.strategy != "learn":
            settings = None
        out[plan_id] = (settings, priors_of(started))
    return out


def _operations(session: Session, picked: ColumnElement[bool]) -> dict[int, tuple[str, Operation]]:
    """The ``picked`` operations by id, each with its tool's name, read once (not a quantity)."""
    o = t.Operation
    rows = session.execute(
        select(o, t.Tool.name).join(t.Tool, o.tool_id == t.Tool.id).where(picked)
    )
    return {row.id: (tool, _operation(row, tool)) for row, tool in rows}


def _operation(row: t.Operation, tool: str) -> Operation:
    """The stored operation as far as its prior needs it (bounds, context, limits)."""
    return Operation(
        name=row.name,
        process=row.process,  # type: ignore[arg-type]
        tool=tool,
        volume_mm3=row.volume_mm3,
        limits={str(k): float(v) for k, v in row.limits.items()},
        bounds={str(k): (float(v[0]), float(v[1])) for k, v in row.bounds.items()},
        context={str(k): float(v) for k, v in row.context.items()},
    )


def prior_json(priors: Mapping[tuple[str, str], FleetPrior]) -> dict[str, Any] | None:
    """``plans.prior`` of a plan's fleet priors (None: it starts from the catalogue)."""
    if not priors:
        return None
    return {
        f"{op}|{quantity}": {
            "posterior": p.posterior.to_json(),
            "provenance": provenance_json(p.provenance),
        }
        for (op, quantity), p in sorted(priors.items())
    }


def provenance_json(p: Provenance) -> dict[str, Any]:
    """A prior's provenance as stored and answered (REST, ``--json``)."""
    return {
        "quantity": p.quantity,
        **listed("plans", p.plans),
        **listed("machines", p.machines),
        "between_machine_spread": p.spread,
        "operation_spread": p.operation_spread,
        "readings": p.readings,
        # the band's optimum checked at this sd, and why: the machines differ by more than
        # the catalogue band ("spread"), a plan of the tool halted ("halted")
        "band_checked_at_sd": p.band_checked_at_sd,
        "band_checked_because": list(p.band_checked_why),
        # the tool's plans the fleet left out, by why (db.fleet_left_out)
        "left_out": asdict(p.left_out),
        "widened_by_part": None,  # a part whose readings let the prior go (:func:`let_go`)
        "text": p.describe(),
    }


def let_go(
    stored: Mapping[str, Any] | None,
    before: Mapping[tuple[str, str], Posterior],
    after: Mapping[tuple[str, str], Posterior],
    serial: str,
) -> dict[str, Any] | None:
    """``plans.prior`` with the fleet priors part ``serial`` let go marked (None: none).

    A quantity whose readings showed the machine outside the fleet's spread
    (:mod:`supervisor.rcb.prior_check`: ``before`` unwidened, ``after`` widened) keeps its
    provenance, with the part that let it go (``widened_by_part``) and the line saying so.
    """
    if not stored:
        return None
    out: dict[str, Any] | None = None
    for (op, quantity), belief in sorted(after.items()):
        key, old = f"{op}|{quantity}", before.get((op, quantity))
        if key not in stored or belief.prior_widening <= 0:
            continue
        if old is not None and old.prior_widening > 0:
            continue
        out = dict(stored) if out is None else out
        out[key] = marked(out[key], "widened_by_part", serial, _OUTSIDE)
    return out


_OUTSIDE = (
    "this machine lies outside the fleet's spread (its ln K learned from the catalogue's band)"
)


def restarted_json(
    stored: Mapping[str, Any] | None, priors: Mapping[tuple[str, str], Posterior]
) -> dict[str, Any] | None:
    """``plans.prior`` with the starts a reset of the bands goes back to (None: no change).

    A prior the machine let go is stored widened (:func:`supervisor.rcb.learning.restarted`);
    its provenance, the part that let it go included, stays.
    """
    if not stored:
        return None
    out = {
        key: {**value, "posterior": priors[_pair(key)].to_json()}
        for key, value in stored.items()
        if _pair(key) in priors
    }
    changed = {k: v for k, v in out.items() if v != stored[k]}
    return {**stored, **changed} if changed else None


def _pair(key: str) -> tuple[str, str]:
    """``(operation, quantity)`` of a ``plans.prior`` key ``OP|QUANTITY``."""
    op, _, quantity = key.rpartition("|")
    return op, quantity


def priors_of(stored: Mapping[str, Any] | None) -> dict[tuple[str, str], Posterior]:
    """The priors of ``plans.prior`` per (operation, quantity) (empty: the catalogue's)."""
    return {_pair(key): posterior_from_json(v["posterior"]) for key, v in (stored or {}).items()}


def prior_answer(
    stored: Mapping[str, Any] | None, noise: Mapping[str, Any] | None = None, names: bool = True
) -> dict[str, Any]:
    """``prior``, ``provenance`` and ``noise_provenance`` of a plan's answers (REST, ``--json``).

    ``noise``: ``plans.noise_prior`` (:mod:`db.fleet_noise`). The plans and machines named
    are at most :data:`db.fleet_names.MAX_NAMED` of each, with their counts. ``names`` False:
    for a key scoped to plans, which may not see the fleet's other plans: their names and
    machines are null, the counts stay, as ``GET /tools/{name}/fleet/law`` gives counts only.
    """
    provenance = {
        op: [bounded(p, names) for p in found] for op, found in provenance_of(stored).items()
    }
    chains = [bounded(p, names) for p in noise_provenance(noise)]
    return {
        "prior": "fleet" if stored else "catalogue",
        "provenance": provenance,
        "noise_provenance": chains,
    }


def provenance_of(stored: Mapping[str, Any] | None) -> dict[str, list[dict[str, Any]]]:
    """Per operation, the provenance of each quantity's prior (empty: the catalogue's)."""
    out: dict[str, list[dict[str, Any]]] = {}
    for key, value in sorted((stored or {}).items()):
        op, _, _ = key.rpartition("|")
        out.setdefault(op, []).append(value["provenance"])
    return out


def _with_left_out(prior: FleetPrior, out: LeftOut | None) -> FleetPrior:
    """``prior`` whose provenance counts its tool's plans the fleet left out (None: none)."""
    if out is None:
        return prior
    return replace(prior, provenance=replace(prior.provenance, left_out=out))


#: What ``--prior`` / ``?prior=`` take.
PRIORS = ("fleet", "catalogue")


def plan_priors(
    *, session: Session, plan: Plan, settings: RcbSettings, prior: str | None
) -> tuple[dict[tuple[str, str], FleetPrior], dict[str, NoisePrior]]:
    """The fleet priors a new plan starts from (empty: the catalogue's), and its chains'.

    The chains' noise priors (:mod:`supervisor.fleet.noise`) come with the fleet's priors of
    the models, from the same plans' monitors; none with the catalogue's.
    Each fleet prior's provenance counts its tool's plans the fleet left out
    (:mod:`db.fleet_left_out`, two statements more, bounded as the evidence is); where one
    of them halted (its first reason), the prior checks the band's optimum at 2 sd
    (:func:`supervisor.fleet.prior._prior`).

    ``prior``: ``fleet``, ``catalogue`` or None (the fleet's where the database holds evidence
    for the plan's tools and the plan learns, else the catalogue's).

    Raises
    ------
    InputError
        ``prior`` is none of :data:`PRIORS`; or ``fleet`` for a strategy other than ``learn``,
        with ``exponent_sd`` 0, or with no stored evidence for the plan's tools.
    """
    if prior is not None and prior not in PRIORS:
        raise InputError("prior", prior, f"must be one of {', '.join(PRIORS)}")
    if prior == "catalogue" or (prior is None and settings.strategy != "learn"):
        return {}, {}
    if settings.strategy != "learn":
        raise InputError(
            "prior", prior, f"only learn starts from a fleet prior, not {settings.strategy}"
        )
    if prior == "fleet" and settings.exponent_sd <= 0:  # the catalogue's prior it starts from
        raise InputError(
            "exponent_sd",
            settings.exponent_sd,
            "a fleet prior is learned exponents and all: it needs exponent_sd > 0 (the"
            " exponents known exactly take no evidence); or use prior catalogue",
        )
    tools = {op.name: op.tool for op in plan.operations}
    learned = fleet_evidence(session=session, tool_names=tools.values())
    outs = left_out(session=session, tool_names=tools.values()) if learned else {}
    halted = {tool for tool, out in outs.items() if out.halted}
    priors = fleet_priors(
        plan, learned, settings.coverage_k, settings.exponent_sd, settings.edge_sd, halted=halted
    )
    priors = {(op, q): _with_left_out(p, outs.get(tools[op])) for (op, q), p in priors.items()}
    if prior == "fleet" and not priors:
        raise InputError(
            "prior",
            prior,
            "no learn plan in the fleet has measured this plan's tools (rcb fleet show TOOL:"
            " which plans are out, and why): use catalogue",
        )
    return priors, noise_priors(learned) if priors else {}
