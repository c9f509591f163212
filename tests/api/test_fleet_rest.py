"""The fleet prior through the real server (issue 32): two plans on two machines of the virtual
fleet learn over REST, a third starts from them, faster than the catalogue, and says so."""

from __future__ import annotations

import copy
import json
import uuid
from typing import Any

import httpx
import numpy as np
from test_service import BODY

from api.cli.main import app
from supervisor.inputs.plan import plan_from_mapping
from supervisor.virtual.fleet import noise_seed, sample_fleet
from supervisor.virtual.simulate import run_part

#: The virtual fleet (scenario 11, four machines): one law per tool, a ln K offset per machine.
FLEET = sample_fleet(plan_from_mapping(BODY), 11, 4)


def _body(tag: str, machine: int) -> dict[str, Any]:
    body = copy.deepcopy(BODY)
    body["name"], body["machine"]["name"] = f"fleet-{tag}", f"lathe-{tag}-{machine}"
    return body


def _learn(eng, mes, tag: str, machine: int, parts: int) -> int:  # type: ignore[no-untyped-def]
    """A plan on ``machine`` of the fleet, from the catalogue, after ``parts`` parts: its id."""
    created = eng.post("/plans", json=_body(tag, machine), params={"prior": "catalogue"})
    assert created.status_code == 201, created.text
    plan_id = created.json()["id"]
    rng = np.random.default_rng(noise_seed(11, machine))
    for i in range(parts):
        current = mes.get(f"/plans/{plan_id}/setpoints").json()
        setpoints = {op["name"]: op["setpoint"] for op in current["operations"]}
        outcome = run_part(FLEET[machine], setpoints, rng)
        body = outcome.report(f"{tag}-{machine}-{i}", current["setpoint_version"])
        r = mes.post(
            f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": body["serial"]}
        )
        assert r.status_code == 201, r.text
    return int(plan_id)


def test_a_third_machine_starts_from_two_and_the_setpoints_say_so(server, runner) -> None:
    tag = uuid.uuid4().hex[:8]
    with server.client("engineer") as eng, server.client("mes") as mes:
        _learn(eng, mes, f"{tag}-a", 0, 10)
        _learn(eng, mes, f"{tag}-b", 1, 10)
        fleet = eng.post("/plans", json=_body(f"{tag}-c", 2))
        catalogue = eng.post("/plans", json=_body(f"{tag}-d", 3), params={"prior": "catalogue"})
        assert fleet.status_code == catalogue.status_code == 201, fleet.text
        assert fleet.json()["prior"] == "fleet"
        assert fleet.json()["cycle_time_min"] < catalogue.json()["cycle_time_min"]
        setpoints = mes.get(f"/plans/{fleet.json()['id']}/setpoints").json()
        shown = mes.get(f"/plans/{fleet.json()['id']}").json()
    assert setpoints["prior"] == shown["prior"] == "fleet"
    assert setpoints["provenance"] == shown["provenance"] == fleet.json()["provenance"]
    line = setpoints["provenance"]["rough-od"][0]
    assert line["plans"] == [f"fleet-{tag}-a", f"fleet-{tag}-b"]
    assert line["readings"] == 20
    assert line["text"].startswith("force_N: prior from 2 plans on 2 machines")
    # the measuring chains' noise priors, from the same two machines (supervisor.fleet.noise)
    noise = setpoints["noise_provenance"]
    assert noise == shown["noise_provenance"] == fleet.json()["noise_provenance"] != []
    assert all(p["machines"] == sorted(p["machines"]) and len(p["machines"]) == 2 for p in noise)
    assert all(p["let_go_by_part"] is None and " noise: " in p["text"] for p in noise)
    # a key scoped to the new plan may not see the fleet's other plans: no names, the counts
    made = runner.invoke(
        app,
        ["keys", "create", "--role", "viewer", "--plan", str(fleet.json()["id"]), "--json"]
        + ["--db", server.url],
    )
    assert made.exit_code == 0, made.output
    headers = {"Authorization": f"Bearer {json.loads(made.stdout)['key']}"}
    with httpx.Client(base_url=server.base, headers=headers, timeout=60.0) as scoped:
        for path in (f"/plans/{fleet.json()['id']}/setpoints", f"/plans/{fleet.json()['id']}"):
            seen = scoped.get(path).json()
            line = seen["provenance"]["rough-od"][0]
            assert line["plans"] is None and line["machines"] is None, path
            assert line["text"] == setpoints["provenance"]["rough-od"][0]["text"], path
            assert line["readings"] == 20, path
            assert all(p["machines"] is None for p in seen["noise_provenance"]), path
            assert f"fleet-{tag}-a" not in json.dumps(seen) and "lathe-" not in json.dumps(
                seen["provenance"]
            ), path
    # what the fleet left out of the tool's plans is said too: b's machine taken out
    out = runner.invoke(
        app,
        ["fleet", "exclude", "--machine", f"lathe-{tag}-b-1", "--reason", "loose spindle"]
        + ["--db", server.url],
    )
    assert out.exit_code == 0, out.output
    with server.client("engineer") as eng:
        later = eng.post("/plans", json=_body(f"{tag}-e", 3))
    assert later.status_code == 201, later.text
    line = later.json()["provenance"]["rough-od"][0]
    assert line["plans"] == [f"fleet-{tag}-a"]
    assert line["left_out"]["taken_out"] >= 1  # the server's other tests may take out more
    assert "of its tool left out (" in line["text"] and "taken out" in line["text"]


def test_a_prior_that_is_not_one_is_a_problem_naming_it(server) -> None:
    with server.client("engineer") as eng:
        r = eng.post("/plans", json=_body(uuid.uuid4().hex[:8], 0), params={"prior": "flet"})
    assert r.status_code == 422
    assert r.headers["content-type"].startswith("application/problem+json")
    assert "prior" in r.text and "flet" in r.text


def _fleet_of(client, tool: str, limit: int) -> list[dict[str, Any]]:  # type: ignore[no-untyped-def]
    """Every plan of GET /tools/{tool}/fleet, a page of ``limit`` at a time (at most 50)."""
    return pages(client, f"/tools/{tool}/fleet", "plans", limit)


def pages(client, path: str, key: str, limit: int) -> list[dict[str, Any]]:  # type: ignore[no-untyped-def]
    """Every ``key`` item of GET ``path``, a page of ``limit`` at a time (at most 50 pages)."""
    found, cursor = [], None
    for _ in range(50):
        params = {"limit": limit, **({"cursor": cursor} if cursor else {})}
        r = client.get(path, params=params)
        assert r.status_code == 200, r.text
        found += r.json()[key]
        cursor = r.json()["next_cursor"]
        if cursor is None:
            return found
    raise AssertionError("more than 50 pages")


def test_the_fleet_of_a_tool_over_rest_says_who_is_in_and_a_scoped_key_sees_its_own(
    server, runner
) -> None:
    """GET /tools/{name}/fleet pages the plans using a tool: a learned plan is in, one whose
    machine an engineer took out is not and says why; a key scoped to one plan sees only it;
    an unknown tool is a 404 problem naming it."""
    tag = uuid.uuid4().hex[:8]
    with server.client("engineer") as eng, server.client("mes") as mes:
        _learn(eng, mes, f"{tag}-a", 0, 2)
        _learn(eng, mes, f"{tag}-b", 1, 2)
        listed = {p["plan"]: p for p in _fleet_of(mes, "VCMR331", 2)}
        newest = mes.get("/tools/VCMR331/fleet", params={"limit": 1, "order": "newest"}).json()
        older = mes.get(
            "/tools/VCMR331/fleet",
            params={"limit": 1, "order": "newest", "cursor": newest["next_cursor"]},
        ).json()
        missing = eng.get("/tools/NO-SUCH-TOOL/fleet")
    # newest first (a year's plant: the fleet's plans were on the last pages), cursor "n" + id
    assert [p["plan"] for p in newest["plans"] + older["plans"]] == [
        f"fleet-{tag}-b",
        f"fleet-{tag}-a",
    ]
    assert newest["next_cursor"] == f"n{newest['plans'][0]['plan_id']}"
    a, b = listed[f"fleet-{tag}-a"], listed[f"fleet-{tag}-b"]
    assert a["in_fleet"] and a["out"] == "" and a["readings"] == 8
    assert a["operations"] == ["rough-grooves", "rough-contour"]
    assert missing.status_code == 404
    assert missing.headers["content-type"].startswith("application/problem+json")
    assert "NO-SUCH-TOOL" in missing.text
    out = runner.invoke(
        app,
        ["fleet", "exclude", "--machine", b["machine"], "--reason", "loose spindle"]
        + ["--db", server.url],
    )
    assert out.exit_code == 0, out.output
    with server.client("viewer") as viewer:
        again = {p["plan"]: p for p in _fleet_of(viewer, "VCMR331", 100)}
    assert not again[b["plan"]]["in_fleet"]
    assert "loose spindle" in again[b["plan"]]["out"]
    key = runner.invoke(
        app,
        ["keys", "create", "--role", "viewer", "--plan", str(a["plan_id"]), "--json"]
        + ["--db", server.url],
    )
    assert key.exit_code == 0, key.output
    secret = json.loads(key.stdout)["key"]
    headers = {"Authorization": f"Bearer {secret}"}
    with httpx.Client(base_url=server.base, headers=headers, timeout=60.0) as scoped:
        assert [p["plan"] for p in _fleet_of(scoped, "VCMR331", 100)] == [a["plan"]]
