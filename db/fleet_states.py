"""The band state of a plan's operation and tool quantity the fleet reads (issue 32)."""

from __future__ import annotations

from sqlalchemy import ScalarSelect, func, or_, select
from sqlalchemy.orm import aliased

from db import tables as t


def newest_state(*, before_change: bool = False) -> ScalarSelect[int]:
    """The id of the newest band state of the outer query's operation and tool quantity.

    Correlated with ``operations`` and ``tool_models``; an index seek on ``band_states
    (operation_id, quantity, part_id)``. States of parts a replan's ``reset_bands`` forgot are
    left out (as :func:`db.state.load_state` leaves them): none until a part after it.
    ``before_change``: the newest before the part the plan's process changed at, where one is
    pending (``plans.fleet_change_part``; correlated with ``plans`` too).
    """
    newest, revision = aliased(t.BandState), aliased(t.PlanRevision)
    reset = (
        select(func.coalesce(func.max(revision.bands_reset_after_part), 0))
        .where(revision.plan_id == t.Operation.plan_id, revision.reset_bands.is_(True))
        .correlate(t.Operation)
        .scalar_subquery()
    )
    query = (
        select(newest.id)
        .where(newest.operation_id == t.Operation.id, newest.quantity == t.ToolModel.quantity)
        .where(newest.part_id > reset)
    )
    if before_change:
        cut = t.Plan.fleet_change_part
        query = query.where(or_(cut.is_(None), newest.part_id < cut))
    return query.order_by(newest.part_id.desc()).limit(1).scalar_subquery()
