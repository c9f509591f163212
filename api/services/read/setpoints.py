"""The setpoints in force of a plan: what the MES reads before it makes the next part."""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine

from api.services import to_json
from api.services.errors import PlanHaltedError
from api.services.read.common import _plan, _read
from db.fleet import prior_answer
from db.plans import setpoints_of


def current_setpoints(*, engine: Engine, plan_id: int, names: bool = True) -> dict[str, Any]:
    """The setpoints in force; a halted plan has none (:class:`PlanHaltedError`).

    ``names`` False: the prior's provenance without the fleet's plans' and machines' names
    (a key scoped to plans, :func:`db.fleet.prior_answer`).
    """
    with _read(engine) as session, session.begin():
        row = _plan(session, plan_id)
        if row.halt is not None:
            raise PlanHaltedError(plan_id, row.halt)
        version = row.current_setpoint_version
        result = setpoints_of(session=session, plan_row=row, version=version)
    return {
        "plan_id": plan_id,
        "setpoint_version": version,
        **prior_answer(row.prior, row.noise_prior, names),
        "operations": to_json.plan_json(result)["operations"],
    }
