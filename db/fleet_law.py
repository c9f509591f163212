"""What the fleet learned of a tool's law, from the database (``rcb fleet law``)."""

from __future__ import annotations

from sqlalchemy.orm import Session

from db.fleet import fleet_evidence
from db.library import load_tools
from models.catalogue import catalogue
from supervisor.fleet.law import FleetLaw, fleet_law
from supervisor.fleet.prior import tool_beliefs
from supervisor.rcb.state import RcbSettings


def tool_law(*, session: Session, tool: str) -> list[FleetLaw]:
    """What the fleet learned of ``tool``'s law, per quantity (``rcb fleet law``).

    From the evidence a new plan's fleet prior reads, at a new plan's default settings, the
    spreads from the tool's own quantities (:func:`supervisor.fleet.prior.tool_beliefs`).
    Empty: no plan in the fleet measured the tool.
    """
    learned = fleet_evidence(session=session, tool_names=[tool])
    if not learned:
        return []
    # this database's tool, else the packaged catalogue's (as a plan reads it), not an
    # imported document's own copy
    stored = (
        load_tools(session=session, names=[tool]).get(tool)
        or catalogue().get(tool)
        or learned[0].tool
    )
    defaults = RcbSettings()
    beliefs = tool_beliefs(
        stored, learned, defaults.coverage_k, defaults.exponent_sd, defaults.edge_sd
    )
    return [fleet_law(belief) for belief in beliefs.values()]
