"""``rcb plans`` and ``rcb history`` of a halted plan name every change that resumes it.

The hint said ``(--limit, --model or --reset-bands)``: ``--bound`` and ``--rcb`` resume a
halted plan too (any replan that changes something does; ``--reason`` and ``--dry-run``
alone do not). Now it names the options as ``rcb replan`` refuses a replan with none of them,
on one line within 80 columns for any plan id.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from api.cli.replan import CHANGE_OPTIONS
from db import tables as t
from db.plan_state import halt_json
from supervisor.rcb.state import Halt, HaltedOperation

from conftest import DEMO_PLAN, engine_url, invoke


def _halt(engine, plan_id: int) -> None:  # type: ignore[no-untyped-def]
    breach = "force_N 2900 N past its limit 2000 N by 45% (halt_over 25%)"
    halted = HaltedOperation("rough-od", (), (), breach)
    with Session(engine) as session, session.begin():
        plan = session.get(t.Plan, plan_id)
        assert plan is not None
        plan.halt = halt_json(Halt((halted,)))


def test_the_hint_names_every_change_that_resumes_and_one_resumes(engine, runner) -> None:
    url = engine_url(engine)
    assert invoke(runner, "plans", "create", str(DEMO_PLAN), "--db", url).exit_code == 0
    _halt(engine, 1)
    for command in (["plans"], ["history", "1"]):  # where the halt's conflicts are shown
        shown = invoke(runner, *command, "--db", url)
        assert shown.exit_code == 0, shown.output
        (hint,) = [line for line in shown.output.splitlines() if "resume:" in line]
        assert hint == "  resume: rcb replan 1 (--limit/--bound/--model/--rcb/--reset-bands)"
    assert CHANGE_OPTIONS in hint  # the options rcb replan takes as a change, not restated
    assert len(hint.replace(" 1 ", f" {t.MAX_INT} ")) <= 80  # the longest id still fits
    # --bound and --rcb, which the hint left out, resume it as the others do
    for change in (["--rcb", "alpha=0.3"], ["--bound", "rough-od.feed_mm_rev=0.2:0.6"]):
        done = invoke(runner, "replan", "1", *change, "--db", url)
        assert done.exit_code == 0, done.output
        shown = invoke(runner, "history", "1", "--db", url)
        assert "HALTED" not in shown.output and "resume:" not in shown.output
        _halt(engine, 1)
