"""Issue 17, item 4: no input makes a 500. Extreme floats and odd Unicode through every route.

Against a real ``rcb serve`` on SQLite and PostgreSQL. Every route of the OpenAPI document (and
the web view's) gets, in turn at every path parameter, query parameter, body leaf and body key,
each token below spelled as raw JSON (``NaN``, ``"\\ud800"``, a 40-digit integer) or as URL
text. No answer may be a 5xx; an answer of the REST service that refuses the input must be
problem+json naming a field, and a 422 must name the swept field (or the part of it that is
wrong, as a domain reader names it: ``operations.rough-od.limits`` for a bound).
"""

from __future__ import annotations

import copy
import itertools
import json
import re
from collections import Counter
from typing import Any

import httpx

from api.rest.schemas.plans import PLAN_EXAMPLE

#: Extreme numbers, as JSON text: the largest, the least subnormal, minus zero, integers past
#: any column (and past the 4300 digits Python's parser reads), the non-JSON words Python's
#: parser takes, and a literal past a float's range.
FLOATS = ["1e308", "-1e308", "5e-324", "-0.0", "1" + "0" * 40, "-" + "9" * 30, "9" * 5000,
          "NaN", "Infinity", "-Infinity", "1e400"]  # fmt: skip
#: Odd text, as JSON: lone surrogates, NUL, controls and an ANSI escape, bidi and RTL marks, a
#: long string, the empty string, a number as a string, and the wrong JSON types.
STRINGS = ['"\\ud800"', '"a\\udfffb"', '"\\u0000"', '"SN\\u0001\\u001b[2J\\u007f"',
           '"\\u202eevil\\u200f"', '"' + "x" * 5000 + '"', '""', '"5"', "true", "null",
           "[]", "{}"]  # fmt: skip
#: The same in a URL (path segment or query value).
URL_TOKENS = ["1e308", "-1e308", "5e-324", "-0.0", "9" * 40, "NaN", "Infinity", "%ED%A0%80",
              "%00", "%01%1B", "%E2%80%AE%E2%80%8F", "x" * 3000, "true", "%20"]  # fmt: skip
MARK = "@@SWEPT@@"

PLAN = copy.deepcopy(PLAN_EXAMPLE["one operation"]["value"])
PLAN["description"] = "swept"
PLAN["operations"][0]["setpoint_rel_uncertainty"] = {"feed_mm_rev": 0.01}
TOOL = {
    "name": "SWEEP-1",
    "process": "turning",
    "description": "a tool of the sweep",
    "models": {"force_N": {"K": 2000.0, "dK": 200.0, "exponents": {"depth_mm": 0.9}}},
}
REPLAN = {
    "limits": {"rough-od.force_N": 1900.0},
    "bounds": {"rough-od.depth_mm": [0.5, 2.5]},
    "models": {"CNMG432RN.force_N": {"K": 1700.0, "dK": 200.0}},
    "reset_bands": False,
}


def _report(setpoints: dict[str, Any]) -> dict[str, Any]:
    op = setpoints["operations"][0]
    force, roughness = op["predicted"]["force_N"]["value"], op["predicted"]["roughness_um"]
    return {
        "serial": "SW",
        "setpoint_version": 1,
        "operations": [
            {
                "name": op["name"],
                "measurements": {
                    "force_N": {"value": force, "uncertainty": 3.0},
                    "roughness_um": {"value": roughness["value"], "uncertainty": 0.05},
                },
                "tool_wear": {
                    "flank_wear_mm": {"value": 0.1, "uncertainty": 0.01},
                    "volume_mm3": 1e5,
                },  # fmt: skip
                "edge_parts": 3,
            }
        ],
    }


def _leaves(data: Any, path: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    """Every position of ``data`` that holds a scalar, and every dict key (as ``(..., KEY)``)."""
    if isinstance(data, dict):
        out = [(*path, ("KEY", k)) for k in data]  # type: ignore[misc]
        for k, v in data.items():
            out += _leaves(v, (*path, k))
        return out
    if isinstance(data, list):
        return [leaf for i, v in enumerate(data) for leaf in _leaves(v, (*path, i))]
    return [path]


def _swept(body: Any, leaf: tuple[Any, ...], token: str) -> str:
    """``body`` as JSON text with the position ``leaf`` replaced by the raw JSON ``token``."""
    data = copy.deepcopy(body)
    *head, last = leaf
    target = data
    for key in head:
        target = target[key]
    if isinstance(last, tuple):  # a key: renamed to the token (a string)
        target[MARK] = target.pop(last[1])
    else:
        target[last] = MARK
    return json.dumps(data).replace(json.dumps(MARK), token, 1)


def dotted(leaf: tuple[Any, ...]) -> str:
    """The problem ``field`` convention: ``operations[0].measurements.force_N.value``."""
    out = ""
    for part in leaf:
        if isinstance(part, tuple):
            break  # a key: the field is its table
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "body"


def _tokens(path: str) -> list[str]:
    return [t for t in re.split(r"[.\[\]]+", path) if t]


def names_the_leaf(field: str, leaf: str, operation: str = "rough-od") -> bool:
    """``field`` names ``leaf`` or what holds it, by the body's path.

    A replan's ``bounds.OPERATION.PARAMETER`` is the plan's ``operations[i].bounds.PARAMETER``.
    """
    got = [t for t in _tokens(field) if t != "measurements"]
    replanned = re.sub(rf"^(bounds|limits)\.{operation}\.", r"operations[0].\1.", leaf)
    for path in (leaf, replanned):
        want = [t for t in _tokens(path) if t != "measurements"]
        pairs = zip(got, want, strict=False)
        common = list(itertools.takewhile(lambda pair: pair[0] == pair[1], pairs))
        if got and (len(common) == min(len(got), len(want)) and len(common) >= min(2, len(want))):
            return True
    return False


def names(field: str, where: str) -> bool:
    """Whether a 422's ``field`` names the swept place ``where`` (``body:PATH``, ``key:TABLE``,
    ``query:NAME``, ``path:NAME``); a renamed key may be named as unknown or as missing."""
    kind, _, place = where.partition(":")
    if kind == "key":
        return place == "body" or names_the_leaf(field, place)
    if kind == "body":
        return names_the_leaf(field, place)
    return field == place


class Sweep:
    """Sends the swept requests and checks each answer."""

    def __init__(self, client: httpx.Client) -> None:
        self.client, self.n, self.seen = client, itertools.count(), Counter[int]()
        self.failures: list[str] = []

    def send(self, method: str, url: str, where: str, *, content: str | None = None) -> None:
        headers = {"Idempotency-Key": f"sweep-{next(self.n)}"}
        if content is not None:
            headers["Content-Type"] = "application/json"
        try:
            r = self.client.request(method, url, content=content, headers=headers)
        except httpx.TransportError as err:  # the server dropped the connection: a crash
            self.failures.append(f"{method} {url[:120]} [{where[:120]}]: {err!r}")
            return
        self.seen[r.status_code] += 1
        what = f"{method} {url[:120]} [{where[:120]}] -> {r.status_code}: {r.text[:300]}"
        if r.status_code >= 500:
            self.failures.append(what)
        elif r.status_code >= 400 and "/api/v1/" in str(r.url):
            if r.headers.get("content-type") != "application/problem+json":
                self.failures.append("not problem+json: " + what)
            elif not r.json().get("field"):
                self.failures.append("no field: " + what)
            elif len(r.json()["instance"]) > 200:  # an error body echoes at most 200 characters
                self.failures.append("instance echoed whole: " + what)
            elif r.json()["code"] == "invalid" and not r.json().get("errors"):
                self.failures.append("a 422 invalid without errors: " + what)
            elif r.status_code == 422 and r.json()["code"] != "infeasible":
                if not names(r.json()["field"], where):
                    self.failures.append("another field: " + what)

    def body(self, method: str, url: str, body: dict[str, Any], unique: str | None) -> None:
        """Every token at every leaf and key of ``body`` (``unique``: a field made unique)."""
        for leaf in _leaves(body):
            tokens = STRINGS if isinstance(leaf[-1], tuple) else FLOATS + STRINGS
            for token in tokens:
                sent = copy.deepcopy(body)
                if unique is not None and leaf[:1] != (unique,):
                    sent[unique] = f"{body[unique]}-{next(self.n)}"
                if isinstance(leaf[-1], tuple) and not token.startswith('"'):
                    continue
                kind = "key:" if isinstance(leaf[-1], tuple) else "body:"
                self.send(method, url, kind + dotted(leaf), content=_swept(sent, leaf, token))


def test_no_input_makes_a_5xx_on_any_route(server):
    with server.client("engineer") as c:
        created = c.post("/plans", json=PLAN)
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        assert c.post("/tools", json=TOOL).status_code == 201
        report = _report(created.json())
        routes = c.get("/openapi.json").json()["paths"]
    base = server.base.removesuffix("/api/v1")
    with httpx.Client(base_url=base, timeout=60.0, headers={
        "Authorization": f"Bearer {server.keys['engineer']}"}) as client:  # fmt: skip
        sweep = Sweep(client)
        bodies = {
            ("post", "/api/v1/plans"): (PLAN, "name"),
            ("post", "/api/v1/tools"): (TOOL, "name"),
            ("post", "/api/v1/plans/{plan_id}/parts"): (report, "serial"),
            ("post", "/api/v1/plans/{plan_id}/replan"): (REPLAN, None),
        }
        for path, item in routes.items():
            for method, operation in item.items():
                url = path.replace("{plan_id}", str(plan_id)).replace("{name}", TOOL["name"])
                url = url.replace("{part_id}", "1")  # a part's id, stored or not
                for param in operation.get("parameters", []):
                    if param["in"] not in ("path", "query"):
                        continue
                    for token in URL_TOKENS:
                        where = f"{param['in']}:{param['name']}"
                        if param["in"] == "path":
                            sent = path.replace("{" + param["name"] + "}", token)
                            sent = sent.replace("{plan_id}", str(plan_id))
                            sent = sent.replace("{part_id}", "1")
                        else:
                            sent = f"{url}?{param['name']}={token}"
                            if method == "post" and "replan" in path:
                                sent += "&dry_run=true" if param["name"] != "dry_run" else ""
                        content = None
                        if (method, path) in bodies:
                            content = json.dumps(bodies[method, path][0])
                            if bodies[method, path][1]:
                                unique = {**bodies[method, path][0]}
                                unique[bodies[method, path][1]] += f"-q{next(sweep.n)}"
                                content = json.dumps(unique)
                        sweep.send(method.upper(), sent, where, content=content)
                if "requestBody" in operation:
                    assert (method, path) in bodies, f"no sample body for {method} {path}"
                    body, unique = bodies[method, path]
                    if "replan" in path:
                        url += "?dry_run=true"
                    sweep.body(method.upper(), url, body, unique)
        for token in URL_TOKENS:  # the web view: HTML, never a 5xx
            sweep.send("GET", f"/ui/plans/{token}", "path:plan_id")
            login = client.post("/ui/login", data={"key": token.replace("%", "")})
            if login.status_code >= 500:
                sweep.failures.append(f"POST /ui/login {token!r} -> {login.status_code}")
    assert not sweep.failures, f"{len(sweep.failures)} failures:\n" + "\n".join(
        sorted({f[:400] for f in sweep.failures})[:60]
    )
    # the sweep reached past validation: inputs were taken, refused and not found
    assert sweep.seen[201] > 0 and sweep.seen[422] > 100 and sweep.seen[404] > 0, sweep.seen
