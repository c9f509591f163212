"""``rcb fleet exclude --reason`` refuses what a terminal would not show as written.

A review: a reason holding an escape and a line feed (``'a\\x1b[31mb\\nc'``) was stored
(exit 0) and ``rcb fleet show`` wrote the escape to the terminal as it was, recolouring
what followed; ``--by`` refused the same characters. Now refused naming ``--reason``, and
nothing is taken out.
"""

from __future__ import annotations

from test_fleet_db import _learned

from conftest import engine_url, invoke


def test_a_reason_with_an_escape_is_refused_and_nothing_is_taken_out(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    url = engine_url(engine)
    for reason in ("a\x1b[31mb", "loose\nspindle", "a\u200bb"):
        done = invoke(
            runner, "fleet", "exclude", "--plan", "fleet-a", "--reason", reason, "--db", url
        )
        assert done.exit_code == 2, done.output
        assert "--reason" in done.output and "no control or invisible" in done.output
    shown = invoke(runner, "fleet", "show", "CNMG432RN", "--db", url)
    assert shown.exit_code == 0 and " yes" in shown.output, shown.output
    done = invoke(
        runner, "fleet", "exclude", "--plan", "fleet-a", "--reason", "loose spindle", "--db", url
    )
    assert done.exit_code == 0, done.output
