"""A replan says why: ``rcb replan --reason``, REST ``reason``, kept in the audit entry.

A process engineer reading ``rcb audit --plan P`` could not tell why a plan was replanned.
The reason is checked as a fleet exclusion's is (:func:`db.fleet_exclusions.checked_reason`):
stripped, 1 to 500 printable characters; a bad one is refused naming the field (``--reason``,
``reason``) and stores nothing; a dry run keeps none.
"""

from __future__ import annotations

import json

import pytest
from test_replan import _replan_args
from test_service import BODY

from api.cli.main import app
from api.services import read as queries
from db.engine import make_engine

from conftest import renamed

CHANGE = ["--limit", "rough-od.force_N=2200"]
#: Reasons refused, and what each is: empty, blank, one character too long, an escape.
BAD = ["", "   ", "x" * 501, "spindle \x1b[31mred"]
PROBLEM = "application/problem+json"


def _audit(runner, url: str, plan_id: int) -> list[dict]:
    """The plan's replan entries, newest first (``rcb audit --plan P --json``)."""
    done = runner.invoke(app, ["audit", "--db", url, "--plan", str(plan_id), "--json"])
    assert done.exit_code == 0, done.stderr
    return [e for e in json.loads(done.stdout)["entries"] if e["action"] == "replan"]


def _version(url: str, plan_id: int) -> int:
    engine = make_engine(url)
    try:
        return int(queries.get_plan(engine=engine, plan_id=plan_id)["setpoint_version"])
    finally:
        engine.dispose()


@pytest.fixture
def stored(tmp_path) -> tuple[str, list[str]]:
    """A SQLite database with the demonstration plan, and ``rcb replan``'s first arguments."""
    return _replan_args(tmp_path)


def test_rcb_replan_keeps_its_reason_in_the_audit_entry(runner, stored):
    url, args = stored
    plan_id = int(args[1])
    dry = runner.invoke(app, [*args, *CHANGE, "--reason", "what if", "--dry-run"])
    assert dry.exit_code == 0, dry.output
    assert _audit(runner, url, plan_id) == []  # a dry run keeps nothing, its reason neither
    why = "  spindle bearing replaced: 2200 N allowed (ann, shift 2)  "
    done = runner.invoke(app, [*args, *CHANGE, "--reason", why, "--by", "ann"])
    assert done.exit_code == 0, done.output
    plain = runner.invoke(app, [*args, "--limit", "rough-od.force_N=2100"])
    assert plain.exit_code == 0, plain.output
    without, with_reason = _audit(runner, url, plan_id)  # newest first
    assert (with_reason["actor"], with_reason["result"]) == ("cli:ann", "201")
    assert with_reason["detail"] == {"reason": why.strip()}  # stripped, as an exclusion's
    assert without["detail"] is None  # no reason: as before
    assert _version(url, plan_id) == 3


def test_a_refused_replan_keeps_its_reason(runner, stored):
    """A replan refused for its change (a limit of 0 N) keeps the engineer's reason beside
    the refusal, as a refused ``rcb fleet include`` does; nothing is stored."""
    url, args = stored
    plan_id = int(args[1])
    why = "try the spindle at 0 N (ann)"
    done = runner.invoke(app, [*args, "--limit", "rough-od.force_N=0", "--reason", why])
    assert done.exit_code == 2, done.output
    [refused] = _audit(runner, url, plan_id)
    assert refused["result"] == "refused"
    assert refused["detail"]["reason"] == why
    assert refused["detail"]["field"] == "limits.rough-od.force_N", refused["detail"]
    assert _version(url, plan_id) == 1


@pytest.mark.parametrize("dry_run", [False, True])
def test_a_bad_reason_is_refused_naming_the_option_and_nothing_is_stored(runner, stored, dry_run):
    url, args = stored
    plan_id = int(args[1])
    for bad in BAD:
        done = runner.invoke(
            app, [*args, *CHANGE, "--reason", bad, *(["--dry-run"] if dry_run else [])]
        )
        assert done.exit_code == 2, done.output
        [line] = done.stderr.splitlines()
        assert line.startswith("rcb: error: --reason = '"), line
        assert "Traceback" not in done.output
    assert _version(url, plan_id) == 1
    refused = _audit(runner, url, plan_id)  # a refused replan is audited, a dry run is not
    assert len(refused) == (0 if dry_run else len(BAD))
    assert all(e["result"] == "refused" for e in refused)


def test_the_reason_over_rest(server, runner):
    """``reason`` in the body, refused as ``reason`` (422 problem+json), on both backends."""
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=renamed(BODY)).json()["id"]
        url = f"/plans/{plan_id}/replan"
        change = {"limits": {"rough-od.force_N": 2200}}
        for bad in [*BAD, 5, ["why"]]:
            r = c.post(url, json={**change, "reason": bad})
            assert r.status_code == 422, r.text
            assert r.headers["content-type"] == PROBLEM
            assert r.json()["field"] == "reason", r.json()  # the value echoed, clipped
            assert r.json()["detail"].startswith("reason = "), r.json()
        alone = c.post(url, json={"reason": "nothing else"})  # a reason is no change
        assert alone.status_code == 422, alone.text
        assert alone.json()["field"] == "body"
        assert alone.json()["errors"][0]["message"] == (
            "nothing to change: give one of limits, bounds, models, reset_bands, rcb"
        )
        assert c.get(f"/plans/{plan_id}/setpoints").json()["setpoint_version"] == 1
        dry = c.post(url, json={**change, "reason": "what if"}, params={"dry_run": True})
        assert dry.status_code == 200, dry.text
        key = {"Idempotency-Key": "why-1"}
        done = c.post(url, json={**change, "reason": " worn insert seat "}, headers=key)
        assert done.status_code == 201, done.text
        again = c.post(url, json={**change, "reason": " worn insert seat "}, headers=key)
        assert again.json() == done.json() and again.headers["Idempotent-Replayed"] == "true"
        other = c.post(url, json={**change, "reason": "another"}, headers=key)
        assert other.status_code == 422, other.text  # another request under the same key
        null = c.post(url, json={"limits": {"rough-od.force_N": 2100}, "reason": None})
        assert null.status_code == 201, null.text
    entries = _audit(runner, server.url, plan_id)
    stored = [e for e in entries if e["result"] == "201"]
    assert [e["detail"] for e in stored] == [None, {"reason": "worn insert seat"}]
    refused = [e for e in entries if e["result"] == "refused"]
    fields = [e["detail"]["field"] for e in reversed(refused)]
    # each bad reason, the two not text, the reason alone, the key sent with another body
    assert fields == ["reason"] * (len(BAD) + 2) + ["changes", "Idempotency-Key"], fields
