"""Creating a plan on a machine an engineer took out of the fleet says so.

``rcb fleet exclude --machine M`` takes every plan of M out, those created later too; ``rcb
plans show`` and ``GET /plans/{id}`` said so in ``fleet_out``, ``rcb plans create`` and
``POST /plans`` did not. Their answer now has ``fleet_out``: what ``GET /plans/{id}`` says,
where the machine is taken out and the plan's strategy learns; null otherwise (a new plan is
out until its first part, and one that learns nothing never is in: neither is worth saying).
"""

from __future__ import annotations

import json
from pathlib import Path

from test_service import BODY

from api.cli.main import app

from conftest import renamed
from migrated import migrated

MACHINE = BODY["machine"]["name"]
WIDTH = 80


def _exclude(runner, url: str) -> None:
    done = runner.invoke(
        app,
        ["fleet", "exclude", "--machine", MACHINE, "--reason", "loose spindle"]
        + ["--by", "ann", "--db", url],
    )
    assert done.exit_code == 0, done.output


def _plan_file(tmp_path: Path, body: dict) -> str:
    path = tmp_path / f"{body['name']}.json"
    path.write_text(json.dumps(body), encoding="utf-8")
    return str(path)


def _create(runner, url: str, path: str, *args: str):
    done = runner.invoke(app, ["plans", "create", path, "--db", url, *args])
    assert done.exit_code == 0, done.output
    return done


def test_rcb_plans_create_on_an_excluded_machine_says_so(runner, tmp_path):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    first = _create(runner, url, _plan_file(tmp_path, BODY))
    assert "fleet" not in first.stderr  # in the fleet (no part yet): nothing said
    assert (
        json.loads(_create(runner, url, _plan_file(tmp_path, renamed(BODY)), "--json").stdout)[
            "fleet_out"
        ]
        is None
    )
    _exclude(runner, url)
    done = _create(runner, url, _plan_file(tmp_path, renamed(BODY)))
    lines = done.stderr.splitlines()
    assert all(len(line) <= WIDTH for line in lines), lines
    said = " ".join(line.strip() for line in lines)
    assert f"rcb: out of the fleet: machine {MACHINE} taken out by cli:ann: loose spindle" in said
    assert f"until rcb fleet include --machine {MACHINE}" in said
    answer = json.loads(_create(runner, url, _plan_file(tmp_path, renamed(BODY)), "--json").stdout)
    shown = runner.invoke(app, ["plans", "show", str(answer["id"]), "--db", url, "--json"])
    assert answer["fleet_out"] == json.loads(shown.stdout)["fleet_out"]  # GET's words
    assert answer["fleet_out"].startswith(f"machine {MACHINE} taken out by cli:ann")
    # a strategy that learns no posterior is never in the fleet: nothing to say
    ivester = _create(
        runner, url, _plan_file(tmp_path, renamed(BODY)), "--strategy", "ivester", "--json"
    )
    assert json.loads(ivester.stdout)["fleet_out"] is None
    # another machine is in the fleet
    other = renamed({**BODY, "machine": {**BODY["machine"], "name": "lathe-c"}})
    quiet = _create(runner, url, _plan_file(tmp_path, other))
    assert "fleet" not in quiet.stderr


def test_post_plans_on_an_excluded_machine_says_so(server, runner):
    """``fleet_out`` in the 201, as ``GET /plans/{id}`` gives it; null in the fleet."""
    other = {**BODY, "machine": {**BODY["machine"], "name": "lathe-rest-in"}}
    with server.client("engineer") as c:
        first = c.post("/plans", json=renamed(BODY))
        assert first.status_code == 201, first.text
        assert first.json()["fleet_out"] is None
        _exclude(runner, server.url)
        out = c.post("/plans", json=renamed(BODY))
        assert out.status_code == 201, out.text
        shown = c.get(f"/plans/{out.json()['id']}").json()
        ivester = c.post("/plans", json=renamed(BODY), params={"strategy": "ivester"})
        key = {"Idempotency-Key": "on-excluded-1"}
        kept = renamed(other)
        once = c.post("/plans", json=kept, headers=key)
        again = c.post("/plans", json=kept, headers=key)
    assert out.json()["fleet_out"] == shown["fleet_out"]
    assert out.json()["fleet_out"].startswith(
        f"machine {MACHINE} taken out by cli:ann: loose spindle"
    )
    assert ivester.status_code == 201 and ivester.json()["fleet_out"] is None
    assert once.status_code == 201 and once.json()["fleet_out"] is None
    assert again.json() == once.json() and again.headers["Idempotent-Replayed"] == "true"
