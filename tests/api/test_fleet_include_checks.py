"""``rcb fleet include`` checks what it puts back, and says when there is nothing to put back.

Before, ``include`` reported success for anything: ``--machine LATHE-B`` (lathe-b stayed
out), a machine no plan was ever of, an ``ivester`` plan that is never in the fleet; and the
audit log recorded each as done. Now an unknown machine or plan, or a plan whose strategy
learns no posterior, is an error naming its option (exit 2, one line, audited as refused);
what is not out is left as it is, said so, exit 0, with no audit entry. A plan out for a
change of its process counted by its monitors is put back as before (the changes accepted).
``exclude`` with both or neither option says so without ``= None``, and refuses a plan that
learns no posterior as ``include`` does. A refused entry keeps the engineer's ``--reason``
(checked) beside what was refused; it dropped it.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session
from test_fleet_db import _body, _learned
from test_fleet_exclusions import _count_changes, _in_fleet

from api.services.fleet_models import exclude_from_fleet, include_in_fleet
from api.services.plans import create_plan
from db import tables as t
from db.fleet_exclusions import OneOfError
from supervisor.rcb.state import RcbSettings

from conftest import engine_url, invoke


def _entries(engine, action: str = "fleet include") -> list[tuple[str, str]]:  # type: ignore[no-untyped-def]
    """The audit log's entries of ``action``: (target, result), oldest first."""
    with Session(engine) as session:
        rows = session.execute(
            select(t.AuditEntry.target, t.AuditEntry.result)
            .where(t.AuditEntry.action == action)
            .order_by(t.AuditEntry.id)
        ).all()
    return [(target, result) for target, result in rows]


def _excluded(engine) -> list[tuple[int | None, str | None]]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        rows = session.execute(select(t.FleetExclusion.plan_id, t.FleetExclusion.machine)).all()
    return [(plan_id, machine) for plan_id, machine in rows]


def test_include_refuses_a_machine_or_plan_it_does_not_know_and_leaves_the_rest(
    engine, runner
) -> None:
    _learned(engine, "fleet-a", 1, 2)
    url = engine_url(engine)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-1", reason="loose spindle")
    done = invoke(runner, "fleet", "include", "--machine", "LATHE-1", "--db", url)
    assert done.exit_code == 2
    # one line to a pipe or a log, whole for grep (filled at 80 columns on a terminal only:
    # tests/api/test_cli_error_terminal.py)
    assert done.output.splitlines() == [
        "rcb: error: --machine = 'LATHE-1': no stored plan or imported model is of this "
        "machine (names are exact: lathe-1?)"
    ]
    assert _excluded(engine) == [(None, "lathe-1")]  # still out
    assert "fleet-a" not in _in_fleet(engine, "CNMG432RN")
    done = invoke(runner, "fleet", "include", "--machine", "nosuch", "--db", url)
    assert done.exit_code == 2 and "--machine = 'nosuch': no stored plan" in done.output
    assert "names are exact" not in done.output
    done = invoke(runner, "fleet", "include", "--plan", "99", "--db", url)
    assert done.exit_code == 2 and "rcb: error: --plan = 99: no such plan" in done.output
    done = invoke(runner, "fleet", "include", "--plan", "nosuch", "--db", url)
    assert done.exit_code == 2 and "--plan = 'nosuch': no plan named" in done.output
    assert _entries(engine) == [
        ("machine LATHE-1", "refused"),
        ("machine nosuch", "refused"),
        ("plan 99", "refused"),
    ]  # plan_of refused 'nosuch' before the use case: nothing to audit
    done = invoke(runner, "fleet", "include", "--machine", "lathe-1", "--db", url)
    assert done.exit_code == 0
    assert "rcb: machine lathe-1 is back in the fleet" in done.output
    assert _excluded(engine) == [] and "fleet-a" in _in_fleet(engine, "CNMG432RN")
    assert _entries(engine)[-1] == ("machine lathe-1", "200")


def test_a_plan_that_learns_no_posterior_is_never_in_the_fleet(engine, runner) -> None:
    ivester = RcbSettings(strategy="ivester")
    made = create_plan(engine=engine, body=_body("vl-f", "lathe-f"), settings=ivester).body
    url = engine_url(engine)
    for plan in ("vl-f", str(made["id"])):
        done = invoke(runner, "fleet", "include", "--plan", plan, "--db", url)
        shown = repr(plan) if plan == "vl-f" else plan
        assert done.exit_code == 2, done.output
        assert done.output.splitlines() == [  # one line, as every error to a pipe
            f"rcb: error: --plan = {shown}: strategy ivester learns no posterior: never in "
            "the fleet"
        ]
        assert "back in the fleet" not in done.output
    assert [result for _, result in _entries(engine)] == ["refused", "refused"]
    # nor taken out: an exclusion of it would be listed by rcb fleet show and change nothing
    args = ("fleet", "exclude", "--plan", "vl-f", "--reason", "wrong bar stock", "--db", url)
    done = invoke(runner, *args)
    assert done.exit_code == 2, done.output
    assert " ".join(done.output.split()) == (
        "rcb: error: --plan = 'vl-f': strategy ivester learns no posterior: never in the fleet"
    )
    assert _excluded(engine) == [] and _entries(engine, "fleet exclude") == [
        (f"plan {made['id']}", "refused")
    ]


def test_nothing_out_is_nothing_to_put_back_and_no_audit_entry(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 0, 2)
    url = engine_url(engine)
    done = invoke(runner, "fleet", "include", "--machine", "lathe-0", "--db", url)
    assert done.exit_code == 0
    assert "rcb: machine lathe-0 is not taken out of the fleet: nothing to put back" in (
        done.output
    )
    done = invoke(runner, "fleet", "include", "--plan", "fleet-a", "--db", url)
    assert done.exit_code == 0
    assert f"rcb: plan {a} is not taken out of the fleet: nothing to put back" in done.output
    assert _entries(engine) == []
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="wrong bar stock")
    assert _in_fleet(engine, "CNMG432RN") == set()
    done = invoke(runner, "fleet", "include", "--plan", "fleet-a", "--db", url)
    assert done.exit_code == 0 and f"rcb: plan {a} is back in the fleet" in done.output
    assert _in_fleet(engine, "CNMG432RN") == {"fleet-a"}
    done = invoke(runner, "fleet", "include", "--plan", "fleet-a", "--db", url)
    assert "nothing to put back" in done.output
    assert _entries(engine) == [(f"plan {a}", "200")]  # the one that put it back


def test_a_plan_out_for_a_change_of_its_process_is_put_back_accepting_it(engine) -> None:
    a = _learned(engine, "fleet-a", 0, 2)
    _count_changes(engine, a, "rough-od", 2)
    assert _in_fleet(engine, "CNMG432RN") == set()  # out by itself, no exclusion
    done = include_in_fleet(engine=engine, plan_id=a, machine=None).body
    assert (done["put_back"], done["changes_accepted"], done["still_out"]) == (True, 2, "")
    assert _in_fleet(engine, "CNMG432RN") == {"fleet-a"}
    with Session(engine) as session:
        plan = session.get(t.Plan, a)
        assert plan is not None and plan.fleet_changes_accepted == 2
    again = include_in_fleet(engine=engine, plan_id=a, machine=None).body
    assert (again["put_back"], again["changes_accepted"]) == (False, 0)
    assert _entries(engine) == [(f"plan {a}", "200")]


def test_a_plan_whose_machine_is_out_is_told_so(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 1, 2)
    url = engine_url(engine)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-1", reason="loose spindle")
    done = invoke(runner, "fleet", "include", "--plan", "fleet-a", "--db", url)
    assert done.exit_code == 0
    text = " ".join(done.output.split())  # filled to 80 columns
    assert (
        f"rcb: plan {a} is not taken out of the fleet itself: nothing to put back; it stays "
        "out: its machine lathe-1 is taken out (rcb fleet include --machine lathe-1)"
    ) in text
    assert all(len(line) <= 80 for line in done.output.splitlines())
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="wrong bar stock")
    done = invoke(runner, "fleet", "include", "--plan", "fleet-a", "--db", url)
    text = " ".join(done.output.split())
    assert f"rcb: plan {a} is put back, but stays out of the fleet: its machine lathe-1" in text
    assert _excluded(engine) == [(None, "lathe-1")]


def test_both_or_neither_of_plan_and_machine_is_said_without_a_value(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 1)
    url = engine_url(engine)
    for command in ("exclude", "include"):
        reason = ["--reason", "x"] if command == "exclude" else []
        both = ["--plan", "fleet-a", "--machine", "lathe-0"]
        done = invoke(runner, "fleet", command, *both, *reason, "--db", url)
        assert done.exit_code == 2, done.output
        assert done.output.strip() == (
            "rcb: error: --plan/--machine: name exactly one of a plan and a machine, not both"
        )
        done = invoke(runner, "fleet", command, *reason, "--db", url)
        assert done.exit_code == 2
        assert done.output.strip() == (
            "rcb: error: --plan/--machine: name exactly one of a plan and a machine, not none"
        )
        assert len(done.output.strip()) <= 80
    assert _excluded(engine) == []
    try:  # the use case refuses it too, and the audit log names both, not "plan None"
        exclude_from_fleet(engine=engine, plan_id=1, machine="lathe-0", reason="x")
    except OneOfError as err:
        assert str(err) == ("--plan/--machine: name exactly one of a plan and a machine, not both")
    else:
        raise AssertionError("both were taken")
    assert _entries(engine, "fleet exclude") == [("plan 1 and machine lathe-0", "refused")]
    done = invoke(runner, "fleet", "exclude", "--plan", "99", "--reason", "x", "--db", url)
    assert done.exit_code == 2 and "rcb: error: --plan = 99: no such plan" in done.output


def _details(engine, action: str) -> list[object]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        rows = session.scalars(
            select(t.AuditEntry.detail)
            .where(t.AuditEntry.action == action)
            .order_by(t.AuditEntry.id)
        )
        return list(rows)


def test_a_refused_exclude_or_include_keeps_the_reason_in_its_entry(engine, runner) -> None:
    _learned(engine, "fleet-a", 1, 2)
    url = engine_url(engine)
    for command in ("exclude", "include"):
        args = ("fleet", command, "--machine", "LATHE-1", "--reason", " loose spindle ")
        done = invoke(runner, *args, "--db", url)
        assert done.exit_code == 2, done.output
        assert _details(engine, f"fleet {command}") == [
            {
                "error": "InputError",
                "field": "--machine",
                "message": "--machine = 'LATHE-1': no stored plan or imported model is of this "
                "machine (names are exact: lathe-1?)",
                "reason": "loose spindle",
            }
        ]
    # a reason refused itself is not kept beside: the message names it, as sent
    done = invoke(runner, "fleet", "exclude", "--machine", "lathe-1", "--reason", " ", "--db", url)
    assert done.exit_code == 2, done.output
    assert _details(engine, "fleet exclude")[-1] == {
        "error": "InputError",
        "field": "--reason",
        "message": "--reason = ' ': give why, in 1 to 500 characters",
    }
