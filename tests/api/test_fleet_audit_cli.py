"""``rcb fleet exclude``/``include`` and ``rcb models export``/``import`` as a user scripts them.

Found by a user's walk through two plants (2026-12-04): excluding a plan already out answered
``plan 1 is out of the fleet (again)`` as if it had just been taken out, the earlier reason
replaced without a word; and these four commands alone of ``rcb fleet`` and ``rcb models``
had no ``--json`` (``No such option: --json``), so a script could not read what they did.
"""

from __future__ import annotations

import json

from test_fleet_db import _learned

from conftest import engine_url, invoke


def test_excluding_what_is_out_says_so_and_which_reason_it_replaces(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 1)
    url = engine_url(engine)
    first = invoke(runner, "fleet", "exclude", "--plan", "fleet-a", "--reason", "bar", "--db", url)
    assert first.exit_code == 0, first.output
    assert "plan 1 is out of the fleet (bar)" in first.output
    again = invoke(runner, "fleet", "exclude", "--plan", "1", "--reason", "1040", "--db", url)
    assert again.exit_code == 0, again.output
    said = " ".join(again.output.split())
    assert "plan 1 was already out of the fleet (taken out by cli:" in said
    assert ": bar); its reason is now: 1040" in said
    assert all(len(line) <= 80 for line in again.output.splitlines())
    done = invoke(runner, "fleet", "exclude", "--plan", "1", "--reason", "x", "--db", url, "--json")
    assert done.exit_code == 0, done.output
    body = json.loads(done.stdout)
    assert (body["excluded"], body["reason"]) == ("plan 1", "x")
    assert body["was"].endswith(": 1040")


def test_a_machine_excluded_twice_names_its_earlier_reason(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 1)
    url = engine_url(engine)
    args = ("fleet", "exclude", "--machine", "lathe-0", "--db", url, "--json", "--reason")
    assert json.loads(invoke(runner, *args, "loose").stdout)["was"] is None
    assert json.loads(invoke(runner, *args, "spindle").stdout)["was"].endswith(": loose")


def test_include_export_and_import_answer_json(engine, runner, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 1)
    url = engine_url(engine)
    invoke(runner, "fleet", "exclude", "--plan", "1", "--reason", "r", "--db", url)
    done = invoke(runner, "fleet", "include", "--plan", "1", "--db", url, "--json")
    assert done.exit_code == 0, done.output
    assert json.loads(done.stdout) == {
        "included": "plan 1",
        "put_back": True,
        "changes_accepted": 0,
        "still_out": "",
    }
    out = tmp_path / "a.json"
    done = invoke(runner, "models", "export", "CNMG432RN", "--out", str(out), "--db", url, "--json")
    assert done.exit_code == 0, done.output
    written = json.loads(done.stdout)
    assert (written["tool"], written["learned"], written["out"]) == ("CNMG432RN", 2, str(out))
    assert written["bytes"] == out.stat().st_size
    done = invoke(runner, "models", "import", str(out), "--db", url, "--json")
    assert done.exit_code == 0, done.output
    assert json.loads(done.stdout) == {
        "stored": 0,
        "new": 0,
        "replaced": 0,
        "kept": 0,
        "own": 2,
        "copied": 0,
        "source": "a.json",
    }
