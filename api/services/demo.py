"""``rcb demo`` on an embedded database: the demonstration stored as a plant's plans are.

The plan is created as ``rcb plans create`` creates it, from the catalogue (a demonstration
starts where the paper does, whatever else the database holds), and each part the virtual
machine makes is reported as ``POST /plans/{id}/parts`` reports it: through the same
transaction, audit log and state the service uses, so that ``rcb history``, ``rcb report``,
``rcb serve`` and its web view show the demonstration afterwards.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services.parts import report_part
from api.services.plans import create_plan
from db.errors import PlanNameTakenError
from db.plans import get_plan_row
from db.read.plans import numbered_names
from db.state import load_state
from models.errors import InputError
from supervisor.inputs.part_report import PartReport
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.virtual.demo import Apply

#: Attempts at a free name when another writer takes the one found free first.
_ATTEMPTS = 3


def demo_plan(*, engine: Engine, body: Mapping[str, Any], settings: RcbSettings) -> dict[str, Any]:
    """The demonstration's plan stored under its name, or ``NAME-2``, ``NAME-3`` … when taken.

    Returns the 201 answer of :func:`api.services.plans.create_plan` (``id``, ``name`` …).
    """
    name = str(body.get("name", "")).strip()
    if not name:
        raise InputError("name", body.get("name"), "the demonstration's plan needs a name")
    for _ in range(_ATTEMPTS):
        with Session(engine) as session:
            taken = numbered_names(session=session, name=name)
        free = name if name not in taken else _next(name, taken)
        try:
            return create_plan(
                engine=engine, body={**body, "name": free}, settings=settings, prior="catalogue"
            ).body
        except PlanNameTakenError:
            continue  # taken meanwhile: look again
    raise InputError("name", name, f"no free name after {_ATTEMPTS} attempts; try again")


def stored(engine: Engine, plan_id: int) -> Apply:
    """An :data:`~supervisor.virtual.demo.Apply` that reports each part to plan ``plan_id``.

    Returns the state the service holds for the next part and the measurements it flagged.
    """

    def apply(made_with: RcbState, report: PartReport) -> tuple[RcbState, int]:
        answer = report_part(engine=engine, plan_id=plan_id, report=report).body
        with Session(engine) as session, session.begin():
            row = get_plan_row(session=session, plan_id=plan_id, lock=True)
            assert row is not None  # stored by demo_plan; rcb demo deletes nothing
            state = load_state(session=session, plan_row=row)
        return state, sum(1 for u in answer["updates"] if u["flagged"])

    return apply


def _next(name: str, taken: set[str]) -> str:
    """``NAME-N`` with N one above the highest taken (2 when only NAME is)."""
    tails = (n[len(name) + 1 :] for n in taken)
    numbers = [int(tail) for tail in tails if tail.isascii() and tail.isdigit()]
    return f"{name}-{max(numbers, default=1) + 1}"
