"""GET /tools/{name}/fleet/imported through the real server (issue 32): the machines of a
tool's imported models, a page at a time, by the names an engineer takes them out by."""

from __future__ import annotations

import json
import uuid
from typing import Any

import httpx
from test_fleet_rest import _learn, pages

from api.cli.main import app


def _pages(client, tool: str, limit: int) -> list[dict[str, Any]]:  # type: ignore[no-untyped-def]
    return pages(client, f"/tools/{tool}/fleet/imported", "machines", limit)


def test_imported_machines_page_by_name_and_show_who_took_one_out(server, runner, tmp_path) -> None:
    tag = uuid.uuid4().hex[:8]
    with server.client("engineer") as eng, server.client("mes") as mes:
        _learn(eng, mes, f"{tag}-a", 0, 2)
        _learn(eng, mes, f"{tag}-b", 1, 2)
    out = tmp_path / "cnmg.json"
    done = runner.invoke(
        app, ["models", "export", "CNMG432RN", "--out", str(out)] + ["--db", server.url]
    )
    assert done.exit_code == 0, done.output
    document = json.loads(out.read_text(encoding="utf-8"))
    for item in document["learned"]:  # as another plant's: this one skips its own
        item["origin"] = "0c5f0b7e-5d1a-4c55-9f43-2b8f3b1a9e21"  # plant one's identity
    out.write_text(json.dumps(document), encoding="utf-8")
    done = runner.invoke(app, ["models", "import", str(out), "--db", server.url])
    assert done.exit_code == 0 and "(4 new)" in done.output, done.output
    names = [f"lathe-{tag}-{s}-{m}@0c5f0b7e" for s, m in (("a", 0), ("b", 1))]
    done = runner.invoke(
        app,
        ["fleet", "exclude", "--machine", names[1], "--reason", "chatter", "--db", server.url],
    )
    assert done.exit_code == 0, done.output
    with server.client("viewer") as viewer:
        listed = _pages(viewer, "CNMG432RN", 1)
        missing = viewer.get("/tools/NO-SUCH-TOOL/fleet/imported")
        bad = viewer.get("/tools/CNMG432RN/fleet/imported", params={"cursor": "bm90IGEgY3Vyc29y"})
    assert [m["machine"] for m in listed] == names
    assert [(m["models"], m["readings"], m["in_fleet"]) for m in listed] == [
        (2, 4, True),
        (2, 4, False),
    ]
    assert listed[1]["out"].endswith(": chatter")
    for problem, status, text in ((missing, 404, "NO-SUCH-TOOL"), (bad, 422, "cursor")):
        assert problem.status_code == status
        assert problem.headers["content-type"].startswith("application/problem+json")
        assert text in problem.text
    key = runner.invoke(
        app, ["keys", "create", "--role", "viewer", "--plan", "1", "--json", "--db", server.url]
    )
    secret = json.loads(key.stdout)["key"]
    headers = {"Authorization": f"Bearer {secret}"}
    with httpx.Client(base_url=server.base, headers=headers, timeout=60.0) as scoped:
        assert _pages(scoped, "CNMG432RN", 100) == []  # no plan of this database
