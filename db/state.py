"""A plan's RCB state in the tables: loading it (a part's new state: :mod:`db.store_report`).

The state is the models, band states and setpoints in force. Keyword-only functions given a
session; the caller owns the transaction. Loaded states are cached under
``plans.state_token`` (:mod:`db.state_cache`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from db import tables as t
from db.errors import StoredPlanError
from db.fleet import priors_of
from db.fleet_noise import noise_priors_of
from db.model_versions import latest_models
from db.plan_state import halt_of, plan_settings
from db.plans import PlanRow, operation_rows, setpoints_of
from db.refused import repaired, stored_plan
from db.state_cache import CACHE, database_key
from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.inputs.plan import Plan
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.monitor_state import from_json as monitor_from_json
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json
from supervisor.rcb.state import RcbSettings, RcbState, prior_sigma
from supervisor.rcb.wear import WearRise
from supervisor.rcb.wear import from_json as wear_from_json


def load_state(
    *, session: Session, plan_row: PlanRow, repair: Mapping[str, Any] | None = None
) -> RcbState:
    """The RCB state of a plan as stored: models, band states and setpoints in force.

    Call it with the plan row locked (``get_plan_row(lock=True)``, :mod:`db.plans`): the state
    is then the committed one of ``plan_row.state_token`` and is cached under it
    (:mod:`db.state_cache`). A stored setting or plan this version's check refuses raises
    :class:`~db.errors.StoredSettingsError` or :class:`~db.errors.StoredPlanError`, unless
    ``repair`` (a replan's changes) sets it anew: the state is then read with the changes
    applied (:func:`db.refused.repaired`), and not cached, as it is not what is stored.
    """
    database = database_key(session)
    cached = CACHE.get(database, plan_row.id, plan_row.state_token)
    if cached is not None:
        return cached
    try:
        settings = plan_settings(plan_row)
        plan = stored_plan(session=session, plan_row=plan_row)
    except StoredPlanError:  # a stored setting too (StoredSettingsError)
        if not repair:
            raise
        settings, plan = repaired(session=session, plan_row=plan_row, changes=repair)
        return _load_state(session, plan_row, settings, plan)
    state = _load_state(session, plan_row, settings, plan)
    CACHE.put(database, plan_row.id, plan_row.state_token, state)
    return state


def _load_state(session: Session, plan_row: PlanRow, settings: RcbSettings, plan: Plan) -> RcbState:
    ops = operation_rows(session=session, plan_id=plan_row.id)
    tools: dict[str, Tool] = {}
    sigma: dict[tuple[str, str], float] = {}
    seen: dict[tuple[str, str], float] = {}
    wear: dict[tuple[str, str], WearRise] = {}
    monitors: dict[tuple[str, str], Monitor] = {}
    models_in_force = latest_models(session=session, plan_id=plan_row.id)
    pairs = sorted(
        (ops[op.name].id, quantity)
        for op in plan.operations
        for quantity in plan.tools[op.tool].models
    )
    band_states = _latest_band_states(session, pairs, _bands_reset_after(session, plan_row.id))
    priors = priors_of(plan_row.prior)  # a fleet prior the plan started from (db.fleet)
    beliefs: dict[tuple[str, str], Posterior] = dict(priors)  # until a reading moves them
    for op in plan.operations:
        base = plan.tools[op.tool]
        models = {}
        for quantity, baseline in base.models.items():
            row = models_in_force[(ops[op.name].id, quantity)]
            models[quantity] = PowerLawModel(
                quantity, row.K, row.dK, dict(row.exponents), baseline.source, baseline.reference
            )
            state = band_states.get((ops[op.name].id, quantity))
            if state is None:
                sigma[(op.name, quantity)] = prior_sigma(baseline, settings)
            else:
                sigma[(op.name, quantity)] = state.sigma
                seen[(op.name, quantity)] = state.seen
                if state.posterior is not None:
                    beliefs[(op.name, quantity)] = posterior_from_json(state.posterior)
                if state.wear is not None:
                    wear[(op.name, quantity)] = wear_from_json(state.wear)
                if state.monitor is not None:
                    monitors[(op.name, quantity)] = monitor_from_json(state.monitor)
        tools[op.name] = Tool(
            base.name, base.process, models, base.description, base.material, base.source
        )
    setpoints = setpoints_of(
        session=session, plan_row=plan_row, version=plan_row.current_setpoint_version
    )
    return RcbState(
        plan,
        tools,
        setpoints,
        plan_row.current_setpoint_version,
        settings,
        sigma,
        seen,
        beliefs,
        halt_of(plan_row.halt),
        wear,
        monitors,
        priors,
        noise_priors_of(plan_row.noise_prior),  # a chain's fleet noise prior (db.fleet_noise)
    )


def _bands_reset_after(session: Session, plan_id: int) -> int:
    """The last part whose band states a replan forgot (0: none)."""
    last = session.scalar(
        select(func.max(t.PlanRevision.bands_reset_after_part)).where(
            t.PlanRevision.plan_id == plan_id, t.PlanRevision.reset_bands.is_(True)
        )
    )
    return int(last or 0)


def _latest_band_states(
    session: Session, pairs: list[tuple[int, str]], after_part: int = 0
) -> dict[tuple[int, str], t.BandState]:
    """The newest band state per (operation id, quantity) of ``pairs``, in one query.

    An index seek per pair on ``(operation_id, quantity, part_id)``, no GROUP BY over every
    band-state row: the cost of a cache miss does not grow with the parts reported. States of
    parts up to ``after_part`` are forgotten (a replan reset the bands).
    """
    if not pairs:
        return {}
    b, n = t.BandState, _NEWER.c  # a Core alias: an ORM alias per pair cost 1 ms each
    newest = [
        select(n.id)
        .where(n.operation_id == operation_id, n.quantity == quantity, n.part_id > after_part)
        .order_by(n.part_id.desc())
        .limit(1)
        .scalar_subquery()
        for operation_id, quantity in pairs
    ]
    rows = session.scalars(select(b).where(b.id.in_(newest)))
    return {(row.operation_id, row.quantity): row for row in rows}


#: The band states as the subqueries of :func:`_latest_band_states` read them.
_NEWER = t.core_table(t.BandState).alias("newer")
