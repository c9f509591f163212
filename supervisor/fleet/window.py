"""A machine speaks for a tool by its newest plans: the fleet's evidence is bounded by the plant.

A new plan's fleet prior reads every learned model of its tools (:mod:`.prior`), so without a
bound its cost grows with the plant's history: on SQLite, 4.3 s for 300 plans of the
demonstration program on 3 machines (0.19 s with the bound, 2026-12-02), and a plan created
after a year of daily plans with a common insert waited many seconds. What one machine says
about the fleet is bounded anyway: integrated over its offset, its evidence says at most
``σ_b`` about the fleet's ``ln K`` and ``σ_e e_i`` about each exponent (:mod:`.hierarchy`),
which a few plans of tens of readings each already reach. So each machine speaks for each
tool by its newest :data:`PLANS_PER_MACHINE` plans, and the cost is bounded by the number of
machines, not the plans they made (``benchmarks/closed_loop.py --fleet 4 --learn-plans``:
docs/benchmarks.md, "A machine's newest plans").

Which plans those are is decided where the database can decide it without reading the models
(:mod:`db.fleet`, one windowed statement): plans neither halted nor taken out by an engineer,
that learned a model of the tool. Of those, a plan whose process changed is out until an
engineer puts it back (:mod:`db.fleet`); an older plan of the machine does not stand in for
it, so a machine whose newest plans saw their process change speaks by fewer.
"""

from __future__ import annotations

from collections.abc import Sequence

from supervisor.fleet.learned import Learned

#: The plans of one machine that speak for one tool in the fleet: the newest, by creation.
PLANS_PER_MACHINE = 10


def newest_plans(learned: Sequence[Learned], n: int = PLANS_PER_MACHINE) -> list[Learned]:
    """``learned`` less what is older than each machine's newest ``n`` plans with each tool.

    ``learned`` is in the order its plans were made; the tool is the fleet's key (name,
    process and material). The order is kept.
    """
    kept: dict[tuple[str, str, str, str], list[str]] = {}
    for item in reversed(learned):
        plans = kept.setdefault(_key(item), [])
        if item.plan not in plans and len(plans) < n:
            plans.append(item.plan)
    return [item for item in learned if item.plan in kept[_key(item)]]


def _key(item: Learned) -> tuple[str, str, str, str]:
    """A machine and a tool, by the fleet's key (:func:`supervisor.fleet.prior.same_tool`)."""
    return (item.machine, item.tool.name, item.tool.process, item.tool.material)
