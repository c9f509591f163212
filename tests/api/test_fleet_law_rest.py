"""What the fleet learned of a tool's law, through the real server and the CLI (issue 32):
GET /tools/{name}/fleet/law and ``rcb fleet law``, before any plan learned, after two did on
two machines of the virtual fleet, and after an engineer took one out."""

from __future__ import annotations

import json
import uuid

import httpx
import pytest
from test_fleet_rest import _learn

from conftest import invoke


def test_what_two_machines_learned_of_a_tool_is_shown_and_an_excluded_plan_leaves_it(
    server, runner
) -> None:
    with server.client("viewer") as viewer:
        before = viewer.get("/tools/VCMR331/fleet/law")
        missing = viewer.get("/tools/NO-SUCH-TOOL/fleet/law")
    assert before.status_code == 200, before.text
    assert before.json() == {"tool": "VCMR331", "quantities": []}
    none = invoke(runner, "fleet", "law", "VCMR331", "--db", server.url)
    assert none.exit_code == 0 and "no plan in the fleet measured VCMR331" in none.stderr
    assert missing.status_code == 404 and "NO-SUCH-TOOL" in missing.text
    assert missing.headers["content-type"].startswith("application/problem+json")
    tag = uuid.uuid4().hex[:8]
    with server.client("engineer") as eng, server.client("mes") as mes:
        _learn(eng, mes, f"{tag}-a", 0, 4)
        _learn(eng, mes, f"{tag}-b", 1, 4)
    with server.client("viewer") as viewer:
        law = viewer.get("/tools/VCMR331/fleet/law").json()
    quantities = {q["quantity"]: q for q in law["quantities"]}
    assert sorted(quantities) == ["force_N", "roughness_um"]
    for name, q in quantities.items():
        # rough-grooves and rough-contour both use VCMR331: 2 operations x 4 parts a plan
        assert (q["plans"], q["machines"], q["readings"]) == (2, 2, 16)
        assert q["text"].startswith(f"{name}: prior from 2 plans on 2 machines")
        assert q["law_sd"] < q["catalogue_sd"]
        assert q["new_machine_sd"] ** 2 == pytest.approx(
            q["law_sd"] ** 2 + q["between_machine_spread"] ** 2 + q["operation_spread"] ** 2
        )  # at the reference, a new machine's operation adds both spreads (supervisor.fleet.law)
        # no operation of VCMR331 has an edge limit: the rise over an edge is not shown
        assert [p["name"] for p in q["parameters"]] == ["depth_mm", "feed_mm_rev", "speed_m_min"]
    shown = invoke(runner, "fleet", "law", "VCMR331", "--json", "--db", server.url)
    assert shown.exit_code == 0 and json.loads(shown.stdout) == law
    text = invoke(runner, "fleet", "law", "VCMR331", "--db", server.url)
    assert text.exit_code == 0, text.output
    assert "VCMR331 force_N: prior from 2 plans on 2 machines" in text.stdout
    assert (
        "feed_mm_rev" in text.stdout
        and "Where the machines' readings pin the law best (depth_mm" in text.stdout
    )
    out = invoke(
        runner,
        "fleet",
        "exclude",
        "--plan",
        f"fleet-{tag}-b",
        "--reason",
        "wrong bar stock",
        "--db",
        server.url,
    )
    assert out.exit_code == 0, out.output
    with server.client("viewer") as viewer:
        after = {
            q["quantity"]: q for q in viewer.get("/tools/VCMR331/fleet/law").json()["quantities"]
        }
    for q in after.values():
        assert (q["plans"], q["machines"], q["readings"]) == (1, 1, 8)
    assert after["force_N"]["K"] != quantities["force_N"]["K"]


def test_a_key_scoped_to_a_plan_sees_the_law_without_names(server, runner) -> None:
    """The law holds counts, no plan's or machine's name: a key scoped to plans reads it as
    any viewer does (its plans' own fleet priors show the same counts)."""
    tag = uuid.uuid4().hex[:8]
    with server.client("engineer") as eng, server.client("mes") as mes:
        plan_id = _learn(eng, mes, f"{tag}-s", 2, 1)
    plan = f"fleet-{tag}-s"  # rcb keys create --plan takes a name too
    key = invoke(
        runner, "keys", "create", "--role", "viewer", "--plan", plan, "--json", "--db", server.url
    )
    assert key.exit_code == 0, key.output
    assert json.loads(key.stdout)["plans"] == [plan_id]
    headers = {"Authorization": f"Bearer {json.loads(key.stdout)['key']}"}
    with httpx.Client(base_url=server.base, headers=headers, timeout=60.0) as scoped:
        seen = scoped.get("/tools/VCMR331/fleet/law")
    with server.client("viewer") as viewer:
        everyone = viewer.get("/tools/VCMR331/fleet/law")
    assert seen.status_code == 200, seen.text
    assert seen.json() == everyone.json() and seen.json()["quantities"]
    assert "fleet-" not in seen.text and "lathe-" not in seen.text
