"""``rcb fleet exclude`` and ``rcb fleet include``: which plans make new plans' fleet priors.

A plan or a machine an engineer takes out no longer counts in any new plan's prior (a machine
with a loose spindle, a plan cut on the wrong material); a plan whose process changed is out
by itself until an engineer puts it back, which accepts the changes it counted so far.
"""

from __future__ import annotations

from typing import Annotated

import typer

from api.cli.common import DbOption, errors, existing_engine, plan_of, say
from api.cli.who import ByOption, cli_actor

fleet_app = typer.Typer(
    help="Which plans and machines make new plans' fleet priors (learn's start).",
    no_args_is_help=True,
)

PlanOption = Annotated[
    str | None, typer.Option("--plan", help="A plan, by id or name.", show_default=False)
]
MachineOption = Annotated[
    str | None, typer.Option("--machine", help="A machine, by name.", show_default=False)
]


@fleet_app.command("exclude")
def exclude(
    reason: Annotated[str, typer.Option("--reason", help="Why (kept with the exclusion).")],
    plan: PlanOption = None,
    machine: MachineOption = None,
    db: DbOption = None,
    by: ByOption = None,
) -> None:
    """Take a plan (--plan) or every plan of a machine (--machine) out of the fleet."""
    from api.services.fleet_models import exclude_from_fleet
    from api.settings import database_field, database_url

    with errors():
        actor = cli_actor(by)
        engine = existing_engine(database_url(db), database_field(db))
        plan_id = None if plan is None else plan_of(engine, plan)
        done = exclude_from_fleet(
            engine=engine, plan_id=plan_id, machine=machine, reason=reason, actor=actor
        )
    say(f"rcb: {done.body['excluded']} is out of the fleet ({reason})")


@fleet_app.command("include")
def include(
    plan: PlanOption = None,
    machine: MachineOption = None,
    db: DbOption = None,
    by: ByOption = None,
) -> None:
    """Put a plan or a machine back in the fleet (a plan's changes so far accepted)."""
    from api.services.fleet_models import include_in_fleet
    from api.settings import database_field, database_url

    with errors():
        actor = cli_actor(by)
        engine = existing_engine(database_url(db), database_field(db))
        plan_id = None if plan is None else plan_of(engine, plan)
        done = include_in_fleet(engine=engine, plan_id=plan_id, machine=machine, actor=actor)
    accepted = done.body["changes_accepted"]
    extra = f"; {accepted} changes of its process accepted" if accepted else ""
    say(f"rcb: {done.body['included']} is back in the fleet{extra}")
