"""Each machine speaks for a tool by its newest plans, in memory (supervisor.fleet.window): what
the virtual fleet applies, and what db.fleet_window picks in SQL (tests/db/test_fleet_window.py)."""

from __future__ import annotations

from dataclasses import replace

from hypothesis import given, settings
from hypothesis import strategies as st
from test_fleet_prior import _learned

from supervisor.fleet.window import PLANS_PER_MACHINE, newest_plans


def test_each_machine_keeps_its_newest_plans_per_tool_in_order() -> None:
    grooves = _learned("m", "p", "rough-grooves", [1.0])  # VCMR331: force, roughness
    od = _learned("m", "p", "rough-od", [1.0])  # CNMG432RN
    learned = []
    for i in range(12):  # m1 makes 12 plans with both tools, m2 two with VCMR331 alone
        learned += [replace(item, machine="m1", plan=f"a{i}") for item in grooves + od]
        if i < 2:
            learned += [replace(item, machine="m2", plan=f"b{i}") for item in grooves]
    kept = newest_plans(learned)
    assert PLANS_PER_MACHINE == 10
    assert [x for x in learned if x in kept] == kept  # the order is kept
    assert {x.plan for x in kept if x.machine == "m1"} == {f"a{i}" for i in range(2, 12)}
    assert {x.plan for x in kept if x.machine == "m2"} == {"b0", "b1"}
    assert len(kept) == len(learned) - 2 * len(grooves + od)  # a0, a1 whole, both tools
    assert newest_plans(kept) == kept
    one = newest_plans(learned, 1)
    assert {(x.machine, x.tool.name, x.plan) for x in one} == {
        ("m1", "VCMR331", "a11"),
        ("m1", "CNMG432RN", "a11"),
        ("m2", "VCMR331", "b1"),
    }


#: A learned model of each tool, to be placed on machines and plans by the property below.
_MODELS = _learned("m", "p", "rough-grooves", [1.0])[:1] + _learned("m", "p", "rough-od", [1.0])[:1]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 2), st.integers(0, 1)), max_size=40),
    st.integers(1, 4),
)
def test_newest_plans_keeps_each_machines_newest_n_per_tool(made, n) -> None:
    """Plans made in order, each on a machine with a tool: what is kept is, per machine and
    tool, the last ``n`` distinct plans, every model of them, in the order given."""
    learned = [
        replace(_MODELS[tool], machine=f"m{machine}", plan=f"p{i}")
        for i, (machine, tool) in enumerate(made)
    ]
    kept = newest_plans(learned, n)
    assert [x for x in learned if x in kept] == kept
    for machine in range(3):
        for model in _MODELS:
            plans = [
                x.plan
                for x in learned
                if x.machine == f"m{machine}" and x.tool.name == model.tool.name
            ]
            expected = set(list(dict.fromkeys(reversed(plans)))[:n])
            assert {
                x.plan
                for x in kept
                if x.machine == f"m{machine}" and x.tool.name == model.tool.name
            } == expected
    assert newest_plans(kept, n) == kept
