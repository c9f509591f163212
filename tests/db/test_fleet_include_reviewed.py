"""``rcb fleet include --changes N``: only the changes an engineer reviewed are accepted.

A process engineer's audit: ``include`` accepted every change counted up to the moment it ran,
so one counted between the engineer's look (``rcb fleet show``: ``1 not accepted``) and the
command was accepted unseen. With ``--changes N`` the plan is put back only if it has N changes
not accepted still; else nothing changes and the error names ``--changes`` with the count now.
``--reason`` is kept in the audit entry, with what the include accepted (its detail was null),
and in a refused include's entry too, beside what was refused (a refusal dropped it).
"""

from __future__ import annotations

import json

from sqlalchemy import select
from sqlalchemy.orm import Session
from test_fleet_db import _learned
from test_fleet_exclusions import _count_change, _in_fleet

from api.services.fleet_models import exclude_from_fleet
from api.services.read.fleet import fleet_members
from db import tables as t

from conftest import engine_url, invoke


def _state(engine, plan_id: int) -> tuple[int, list[str]]:  # type: ignore[no-untyped-def]
    """The plan's accepted changes and the reasons of the exclusions stored."""
    with Session(engine) as session:
        plan = session.get(t.Plan, plan_id)
        assert plan is not None
        reasons = list(session.scalars(select(t.FleetExclusion.reason)))
        return plan.fleet_changes_accepted, reasons


def _include_entries(engine) -> list[tuple[str, object]]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        rows = session.execute(
            select(t.AuditEntry.result, t.AuditEntry.detail)
            .where(t.AuditEntry.action == "fleet include")
            .order_by(t.AuditEntry.id)
        ).all()
    return [(result, detail) for result, detail in rows]


def test_a_change_counted_after_the_review_is_not_accepted_unseen(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 0, 3)
    url = engine_url(engine)
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="check spindle")
    _count_change(engine, a)
    seen = fleet_members(engine=engine, tool="VCMR331")["plans"][0]["out"]
    # what the engineer reviewed, and the command that accepts that and nothing counted since
    assert seen.endswith(f"(1 not accepted: rcb fleet include --plan {a} --changes 1)")
    _count_change(engine, a)  # a second, counted after the look
    args = ("fleet", "include", "--plan", "fleet-a", "--changes", "1", "--db", url)
    done = invoke(runner, *args, "--reason", "spindle checked")
    assert done.exit_code == 2, done.output
    assert done.output.splitlines() == [
        f"rcb: error: --changes = 1: plan {a} has 2 changes of its process not accepted now: "
        f"nothing put back (where they were counted: rcb plans show {a})"
    ]
    assert _state(engine, a) == (0, ["check spindle"])  # nothing changed
    assert "fleet-a" not in _in_fleet(engine, "CNMG432RN")
    # the refusal keeps why the engineer asked, beside what was refused (it dropped it)
    assert _include_entries(engine) == [
        (
            "refused",
            {
                "error": "InputError",
                "field": "--changes",
                "message": done.output.removeprefix("rcb: error: ").strip(),
                "reason": "spindle checked",
            },
        )
    ]
    done = invoke(runner, *args[:5], "2", "--db", url, "--reason", " spindle checked ")
    assert done.exit_code == 0, done.output
    said = " ".join(done.output.split())
    assert f"rcb: plan {a} is back in the fleet; 2 changes of its process accepted" in said
    assert _state(engine, a) == (2, [])
    assert "fleet-a" in _in_fleet(engine, "CNMG432RN")
    assert _include_entries(engine)[-1] == (
        "200",
        {"reason": "spindle checked", "changes_accepted": 2, "still_out": ""},
    )
    log = invoke(runner, "audit", "--action", "fleet include", "--json", "--db", url)
    newest = json.loads(log.output)["entries"][0]
    assert newest["detail"]["reason"] == "spindle checked"


def test_changes_zero_puts_back_only_a_plan_with_no_change_waiting(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 0, 3)
    url = engine_url(engine)
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="wrong bar stock")
    _count_change(engine, a)
    args = ("fleet", "include", "--plan", str(a), "--changes", "0", "--db", url)
    done = invoke(runner, *args)
    assert done.exit_code == 2 and "--changes = 0: plan" in done.output
    assert "has 1 change of its process not accepted now" in done.output
    assert _state(engine, a) == (0, ["wrong bar stock"])
    done = invoke(runner, "fleet", "include", "--plan", str(a), "--changes", "1", "--db", url)
    assert done.exit_code == 0 and "1 change of its process accepted" in done.output
    assert _include_entries(engine)[-1] == (
        "200",
        {"reason": None, "changes_accepted": 1, "still_out": ""},
    )
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="again")
    done = invoke(runner, *args)
    assert done.exit_code == 0 and f"rcb: plan {a} is back in the fleet" in done.output


def test_changes_and_reason_are_checked_before_anything_is_put_back(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 0, 3)
    url = engine_url(engine)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-0", reason="loose spindle")
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="wrong bar stock")
    cases = [
        (
            ("--machine", "lathe-0", "--changes", "0"),
            "rcb: error: --changes = 0: a plan's count: give it with --plan, not --machine",
        ),
        (
            ("--plan", "fleet-a", "--changes", "-1"),
            "rcb: error: --changes = -1: a count of changes, 0 or more",
        ),
        (
            ("--plan", "fleet-a", "--reason", "  "),
            "rcb: error: --reason = '  ': give why, in 1 to 500 characters",
        ),
        (
            ("--machine", "lathe-0", "--reason", "fixed\x1b[31m"),
            "rcb: error: --reason = 'fixed\\x1b[31m': one line, no control or invisible characters",
        ),
    ]
    for options, error in cases:
        done = invoke(runner, "fleet", "include", *options, "--db", url)
        assert done.exit_code == 2, (options, done.output)
        assert done.output.splitlines() == [error]
    assert _state(engine, a) == (0, ["loose spindle", "wrong bar stock"])
    assert [result for result, _ in _include_entries(engine)] == ["refused"] * len(cases)
    done = invoke(
        runner, "fleet", "include", "--machine", "lathe-0", "--reason", "fixed", "--db", url
    )
    assert done.exit_code == 0 and "rcb: machine lathe-0 is back in the fleet" in done.output
    assert _include_entries(engine)[-1] == (
        "200",
        {
            "reason": "fixed",
            "changes_accepted": 0,
            "still_out": f"its plan {a} is taken out on its own (rcb fleet include --plan {a})",
        },
    )


def test_a_machine_put_back_says_which_of_its_plans_stay_out(engine, runner) -> None:
    """An audit: ``include --machine`` said ``back in the fleet`` while a plan of the machine
    stayed out on its own exclusion (shown by ``rcb fleet show`` alone)."""
    a = _learned(engine, "fleet-a", 0, 2)
    b = _learned(engine, "fleet-b", 0, 2)
    url = engine_url(engine)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-0", reason="loose spindle")
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="wrong bar stock")
    done = invoke(runner, "fleet", "include", "--machine", "lathe-0", "--db", url)
    assert done.exit_code == 0, done.output
    assert " ".join(done.output.split()) == (
        f"rcb: machine lathe-0 is back in the fleet, but its plan {a} is taken out on its own "
        f"(rcb fleet include --plan {a})"
    )
    assert all(len(line) <= 80 for line in done.output.splitlines())
    assert _in_fleet(engine, "CNMG432RN") == {"fleet-b"}
    exclude_from_fleet(engine=engine, plan_id=b, machine=None, reason="chipped insert")
    done = invoke(runner, "fleet", "include", "--machine", "lathe-0", "--db", url)
    assert " ".join(done.output.split()) == (
        f"rcb: machine lathe-0 is not taken out of the fleet, but its plans {a}, {b} are taken "
        "out on their own (rcb fleet include --plan ID)"
    )
    assert _include_entries(engine)[-1][1] == {
        "reason": None,
        "changes_accepted": 0,
        "still_out": f"its plan {a} is taken out on its own (rcb fleet include --plan {a})",
    }


def test_a_halt_or_an_exclusion_does_not_hide_what_else_keeps_a_plan_out(engine) -> None:
    """An audit: a halted plan said only ``halted`` while it had changes not accepted, which
    a plain ``include`` then accepted unseen (and the replan that resumed it put it straight
    back with the halting part); a plan taken out, then its machine, said only the first."""
    a = _learned(engine, "fleet-a", 0, 3)
    with Session(engine) as session, session.begin():
        plan = session.get(t.Plan, a)
        assert plan is not None
        plan.halt = {"message": "rough-od force_N past its limit", "conflicts": []}
    assert _out(engine) == "halted"
    _count_change(engine, a)
    assert _out(engine) == (
        f"halted; also its process changed (1 not accepted: rcb fleet include --plan {a} "
        "--changes 1)"
    )
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="1040 bar")
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-0", reason="loose spindle")
    assert _out(engine) == (
        "taken out by cli: 1040 bar; also machine lathe-0 taken out by cli: loose "
        f"spindle; also halted; also its process changed (1 not accepted: rcb fleet include "
        f"--plan {a} --changes 1)"
    )


def _out(engine) -> str:  # type: ignore[no-untyped-def]
    (member,) = fleet_members(engine=engine, tool="VCMR331")["plans"]
    return str(member["out"])


def test_a_halted_plan_put_back_says_what_resumes_it(engine, runner) -> None:
    """Its exclusion is gone, but the halt keeps it out until an engineer replans it (issue
    32: a halt takes its evidence out until an engineer puts it back): the include says so,
    with the command, and a replan that resumes it puts it back in the fleet."""
    a = _learned(engine, "fleet-a", 0, 3)
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="1040 bar")
    with Session(engine) as session, session.begin():
        plan = session.get(t.Plan, a)
        assert plan is not None
        plan.halt = {"message": "rough-od force_N past its limit", "conflicts": []}
    url = engine_url(engine)
    done = invoke(runner, "fleet", "include", "--plan", str(a), "--db", url)
    assert done.exit_code == 0, done.output
    said = " ".join(done.output.split())
    assert said.endswith(
        f"stays out of the fleet: it is halted: a replan resumes it (rcb replan {a})"
    )
    assert _out(engine) == "halted"
    # a replan needs a change to make: the alpha the plan has already will do
    resumed = invoke(runner, "replan", str(a), "--rcb", "alpha=0.25", "--db", url)
    assert resumed.exit_code == 0, resumed.output
    assert _in_fleet(engine, "VCMR331") == {"fleet-a"}
