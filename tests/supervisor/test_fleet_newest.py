"""Each machine speaks for a tool by its newest plans, in memory (supervisor.fleet.window): what
the virtual fleet applies, and what db.fleet_window picks in SQL (tests/db/test_fleet_window.py)."""

from __future__ import annotations

from dataclasses import replace

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
