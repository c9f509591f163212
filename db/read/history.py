"""A plan's setpoint history: versions with their setpoints, replan actors, models in force.

Each reads a page's rows, never the plan's whole history; :mod:`api.services.read.history`
shapes them for JSON.
"""

from __future__ import annotations

from collections import defaultdict

from sqlalchemy import select
from sqlalchemy.orm import Session

from db import tables as t


def setpoint_versions(
    *,
    session: Session,
    plan_id: int,
    after: int = 0,
    before: int | None = None,
    limit: int | None = None,
    newest: bool = False,
) -> list[tuple[t.SetpointVersion, str | None, list[t.Setpoint]]]:
    """Setpoint versions of a plan with the causing serial and setpoints, oldest first.

    Parameters
    ----------
    after : int
        Only versions numbered above this one.
    before : int or None
        Only versions numbered below this one.
    limit : int or None
        Most versions returned; ``None``: all. The rows read grow with the page, not with the
        plan's history (the ``(plan_id, version)`` unique index).
    newest : bool
        The newest ``limit`` versions of the range rather than the oldest (still returned
        oldest first).
    """
    query = (
        select(t.SetpointVersion, t.Part.serial)
        .outerjoin(t.Part, t.SetpointVersion.part_id == t.Part.id)
        .where(t.SetpointVersion.plan_id == plan_id, t.SetpointVersion.version > after)
    )
    if before is not None:
        query = query.where(t.SetpointVersion.version < before)
    order = t.SetpointVersion.version.desc() if newest else t.SetpointVersion.version
    versions = list(session.execute(query.order_by(order).limit(limit)).all())
    if newest:
        versions.reverse()
    setpoints: dict[int, list[t.Setpoint]] = defaultdict(list)
    ids = [v.id for v, _ in versions]
    if ids:
        for sp in session.scalars(
            select(t.Setpoint).where(t.Setpoint.setpoint_version_id.in_(ids))
        ):
            setpoints[sp.setpoint_version_id].append(sp)
    return [(v, serial, setpoints[v.id]) for v, serial in versions]


def revision_actors(*, session: Session, plan_id: int, versions: list[int]) -> dict[int, str]:
    """Who made each replan among ``versions``: ``{setpoint version: actor}``.

    The actor is ``key:ID`` (REST) or ``cli:NAME`` (``rcb replan --by``); versions no replan
    made are absent. One index seek per version (``(plan_id, setpoint_version)`` is unique).
    """
    if not versions:
        return {}
    rows = session.execute(
        select(t.PlanRevision.setpoint_version, t.PlanRevision.actor).where(
            t.PlanRevision.plan_id == plan_id, t.PlanRevision.setpoint_version.in_(versions)
        )
    )
    return {int(version): str(actor) for version, actor in rows}


def models_at(
    *, session: Session, operation_ids: list[int], versions: list[t.SetpointVersion]
) -> dict[int, dict[tuple[int, str], t.OperationModelVersion]]:
    """The model versions in force at each setpoint version, per (operation id, quantity).

    In force at a version: the highest-numbered model version among those without a part
    (``initial``, ``replan``) and, for a version a part caused, those of parts up to that part.
    Per page two small queries, each an index seek per setpoint version and (operation,
    quantity), so the cost grows with the page, not with the history.

    Returns
    -------
    dict
        Setpoint version id -> (operation id, quantity) -> model version row.
    """
    if not versions or not operation_ids:
        return {v.id: {} for v in versions}
    m = t.OperationModelVersion
    partless: dict[tuple[int, str], t.OperationModelVersion] = {}
    for row in session.scalars(
        select(m).where(m.operation_id.in_(operation_ids), m.part_id.is_(None)).order_by(m.version)
    ):
        partless[(row.operation_id, row.quantity)] = row  # the highest version stays
    pairs = sorted(partless)
    by_part = [v for v in versions if v.part_id is not None]
    found: dict[int, list[int | None]] = {}
    if by_part and pairs:
        sv = t.SetpointVersion
        columns = []
        newest = _NEWER.c  # a Core alias: an ORM alias per pair cost 1 ms of adaptation each
        for operation_id, quantity in pairs:
            columns.append(
                select(newest.id)
                .where(
                    newest.operation_id == operation_id,
                    newest.quantity == quantity,
                    newest.part_id <= sv.part_id,
                )
                .order_by(newest.part_id.desc(), newest.version.desc())
                .limit(1)
                .correlate(sv)
                .scalar_subquery()
            )
        for hit in session.execute(
            select(sv.id, *columns).where(sv.id.in_([v.id for v in by_part]))
        ):
            found[hit[0]] = list(hit[1:])
    wanted = {i for ids in found.values() for i in ids if i is not None}
    rows = {r.id: r for r in session.scalars(select(m).where(m.id.in_(wanted)))} if wanted else {}
    out: dict[int, dict[tuple[int, str], t.OperationModelVersion]] = {}
    for v in versions:
        in_force = dict(partless)
        for pair, row_id in zip(pairs, found.get(v.id, []), strict=False):
            newer = rows.get(row_id) if row_id is not None else None
            if newer is not None and newer.version > in_force[pair].version:
                in_force[pair] = newer
        out[v.id] = in_force
    return out


#: The model versions as the per-pair subqueries of this module read them.
_NEWER = t.core_table(t.OperationModelVersion).alias("newer")
