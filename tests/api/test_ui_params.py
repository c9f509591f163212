"""The web view's query parameters and its plan list's long names, against a real ``rcb serve``.

An unknown, repeated or malformed query parameter is a 400 page naming it and its value
(escaped), with the view's security headers and a link back to the plan list, where the view
used to show the first page as if it had been asked for. A valid cursor pages as before, and
the sign-in and sign-out forms still work. A 64-character hyphenated plan name folds at 1280 px
only after a ``-`` or ``_`` (``<wbr/>`` between pieces that never break), checked in Debian's
Chromium as well (skipped, saying why, without it or the ``playwright`` package).
"""

from __future__ import annotations

import re
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager

import httpx
import pytest
from test_report_layout import chromium_page, needs_chromium
from test_ui import sign_in

from api.report.html_parts import ONE_LINE_CHARS

from conftest import DEMO_PLAN

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
#: Two 64-character names as a shop writes them: pieces joined by "-" (and one "_").
LONG_NAMES = (
    "finish-od-lathe-12-shaft-4711-rev-c-customer-acme-line-3-cell-07",
    "rough-groove-lathe-12-shaft-4711-rev-c_customer-acme-line-3-op20",
)
#: The headers every page of the view carries (api.report.ui_base.HEADERS).
SECURITY_HEADERS = ("content-security-policy", "x-content-type-options", "referrer-policy")
HOSTILE = "<script>alert(1)</script>"

#: The pieces of each name and machine cell (split after "-" and "_") that span more than one
#: line, and the whole text of such a cell when it has at most ONE_LINE_CHARS characters.
PIECES_BROKEN_JS = """
(oneLine) => {
  const broken = [];
  const cells = '#plans tbody td:nth-child(2), #plans tbody td:nth-child(3)';
  for (const cell of document.querySelectorAll(cells)) {
    const text = cell.textContent;
    const walker = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    const nodes = [];
    for (let n = walker.nextNode(); n; n = walker.nextNode()) nodes.push(n);
    const pieces = text.length <= oneLine ? /.+/g : /[^-_]+[-_]?/g;
    let m;
    while ((m = pieces.exec(text)) !== null) {
      const range = document.createRange();
      let at = 0, start = null, end = null;
      for (const n of nodes) {
        const len = n.textContent.length;
        if (start === null && m.index < at + len) start = [n, m.index - at];
        const last = m.index + m[0].length;
        if (end === null && last <= at + len) end = [n, last - at];
        at += len;
      }
      range.setStart(...start);
      range.setEnd(...end);
      const lines = new Set([...range.getClientRects()]
        .filter(r => r.width > 0).map(r => Math.round(r.bottom)));
      if (lines.size > 1) broken.push([m[0], text]);
    }
  }
  return broken;
}
"""


@pytest.fixture(scope="module")
def plan_ids(server) -> list[int]:
    """Two plans with the long names, in the order created (ids ascending)."""
    ids = []
    with server.client("engineer") as c:
        for name in LONG_NAMES:
            r = c.post("/plans", json={**PLAN, "name": name})
            assert r.status_code == 201, r.text
            ids.append(r.json()["id"])
    return ids


def _ui(server) -> str:
    return f"http://127.0.0.1:{server.port}/ui"


@contextmanager
def _signed_in(server) -> Iterator[httpx.Client]:
    """A client signed in with the viewer's key (the cookie of a session)."""
    with httpx.Client(base_url=_ui(server), timeout=60.0, follow_redirects=False) as client:
        r = client.post("/login", data={"key": server.keys["viewer"]})
        assert r.status_code == 303, r.text
        yield client


def _xml(text: str) -> ET.Element:
    return ET.fromstring(text.removeprefix("<!DOCTYPE html>\n"))


def _text(element: ET.Element | None) -> str:
    assert element is not None
    return "".join(element.itertext()).strip()


def rows(r: httpx.Response) -> list[str | None]:
    """The plan ids of a plan list's rows, in order."""
    return [tr.get("data-plan") for tr in _xml(r.text).iter("tr") if tr.get("data-plan")]


def _assert_refused(r: httpx.Response, name: str, value: str, signed_in: bool = True) -> None:
    """A 400 page naming ``name`` and ``value``, the view's headers and a link to the plans."""
    assert r.status_code == 400, (r.status_code, r.text[:300])
    assert r.headers["content-type"].startswith("text/html")
    for header in SECURITY_HEADERS:
        assert header in r.headers, header
    assert r.headers["cache-control"] == "no-store" and "set-cookie" not in r.headers
    root = _xml(r.text)  # well-formed, as every page of the view
    error = _text(root.find(".//p[@class='error']"))
    assert f"{name} = {value!r}" in error, error
    assert _text(root.find(".//h1")) == "Bad request"
    assert any(a.get("href") == "/ui/" for a in root.iter("a")), "no link to the plan list"
    assert (root.find(".//nav") is not None) == signed_in  # the view's navigation, signed in


# --------------------------------------------------------------------------------------------
# refused parameters


def test_an_unknown_parameter_is_a_400_naming_it(server, plan_ids):
    with _signed_in(server) as c:
        mistyped = c.get("/", params={"afer": str(plan_ids[0])})
        on_plan = c.get(f"/plans/{plan_ids[0]}", params={"cursor": "1"})
        head = c.head("/", params={"afer": "5"})
    _assert_refused(mistyped, "afer", str(plan_ids[0]))
    assert "this page takes cursor" in mistyped.text
    assert 'id="plans"' not in mistyped.text  # not the first page, shown as if asked for
    _assert_refused(on_plan, "cursor", "1")  # a plan's page takes no parameter
    assert "this page takes none" in on_plan.text
    assert head.status_code == 400 and head.content == b""


def test_a_malformed_or_repeated_cursor_is_a_400_naming_it(server, plan_ids):
    with _signed_in(server) as c:
        letters = c.get("/", params={"cursor": "abc"})
        empty = c.get("/?cursor=")
        huge = c.get("/", params={"cursor": "9" * 11})
        twice = c.get(f"/?cursor={plan_ids[0]}&cursor=0")
    _assert_refused(letters, "cursor", "abc")
    _assert_refused(empty, "cursor", "")
    _assert_refused(huge, "cursor", "9" * 11)
    assert twice.status_code == 400 and "given 2 times" in twice.text
    # the list as JSON spells it (models.errors.shown), escaped for HTML
    assert f"cursor = [&quot;{plan_ids[0]}&quot;, &quot;0&quot;]" in twice.text


def test_a_hostile_parameter_is_escaped(server, plan_ids):
    with _signed_in(server) as c:
        as_value = c.get("/", params={"afer": HOSTILE})
        as_name = c.get("/", params={HOSTILE: "x"})
        in_attribute = c.get(f"/plans/{plan_ids[0]}", params={"x": '"><img src=x>'})
    for r in (as_value, as_name, in_attribute):
        assert r.status_code == 400
        assert "<script" not in r.text and "<img" not in r.text
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in as_value.text
    _assert_refused(as_value, "afer", HOSTILE)  # the parsed page says the value as sent
    _assert_refused(as_name, HOSTILE, "x")


def test_a_long_value_is_cut(server, plan_ids):
    with _signed_in(server) as c:
        r = c.get("/", params={"afer": "7" * 5000})
    assert r.status_code == 400 and "7" * 150 in r.text and "7" * 300 not in r.text


def test_valid_cursors_page_as_before(server, plan_ids):
    with _signed_in(server) as c:
        first = c.get("/")
        zero = c.get("/", params={"cursor": "0"})
        after = c.get("/", params={"cursor": str(plan_ids[0])})
        redirected = c.get(_ui(server), params={"cursor": str(plan_ids[0])})
    assert first.status_code == zero.status_code == after.status_code == 200
    assert rows(zero) == rows(first) and str(plan_ids[0]) in rows(first)
    assert str(plan_ids[0]) not in rows(after) and str(plan_ids[1]) in rows(after)
    # /ui keeps the query on its way to /ui/, which judges it
    assert redirected.status_code == 307
    assert redirected.headers["location"] == f"/ui/?cursor={plan_ids[0]}"


def test_without_a_session_a_page_leads_to_the_login_first(server, plan_ids):
    with httpx.Client(base_url=_ui(server), timeout=60.0, follow_redirects=False) as c:
        for path in ("/?afer=5", f"/plans/{plan_ids[0]}?afer=5"):
            r = c.get(path)
            assert (r.status_code, r.headers["location"]) == (303, "/ui/login"), path


def test_login_and_logout_take_no_query_and_still_work(server, plan_ids):
    key = server.keys["viewer"]
    with httpx.Client(base_url=_ui(server), timeout=60.0, follow_redirects=False) as c:
        form = c.get("/login")
        odd_form = c.get("/login", params={"back": "/ui/"})  # it takes next, nothing else
        odd_login = c.post("/login", params={"next": "/ui/"}, data={"key": key})
        assert form.status_code == 200 and 'name="key"' in form.text
        _assert_refused(odd_form, "back", "/ui/", signed_in=False)
        # the post's next comes in the form's body, as its key does: no session opened
        _assert_refused(odd_login, "next", "/ui/", signed_in=False)
        login = c.post("/login", data={"key": key})  # the form's post: the key in the body
        assert (login.status_code, login.headers["location"]) == (303, "/ui/")
        assert c.get("/").status_code == 200
        odd_logout = c.post("/logout", params={"all": "1"})
        _assert_refused(odd_logout, "all", "1", signed_in=False)  # a form's page: no nav
        assert c.get("/").status_code == 200  # nothing done: still signed in
        logout = c.post("/logout")
        assert (logout.status_code, logout.headers["location"]) == (303, "/ui/login")
        assert c.get("/").status_code == 303  # the session ended


# --------------------------------------------------------------------------------------------
# long names


def test_long_names_offer_breaks_only_after_separators(server, plan_ids):
    with _signed_in(server) as c:
        r = c.get("/")
    assert r.status_code == 200
    root = _xml(r.text)
    for plan_id, name in zip(plan_ids, LONG_NAMES, strict=True):
        row = root.find(f".//tr[@data-plan='{plan_id}']")
        assert row is not None
        cell = row.findall("td")[1]
        assert _text(cell) == name
        span = cell.find("span[@class='brk']")
        assert span is not None, ET.tostring(cell, encoding="unicode")
        # the HTML: a <wbr/> only after a "-" or "_", every piece whole
        inner = ET.tostring(span, encoding="unicode")
        before = re.findall(r"(.)<wbr ?/>", re.sub(r"</span>", "", inner))
        assert before and set(before) <= {"-", "_"}, inner
    assert ".nw { white-space: nowrap; }" in r.text  # the pieces' rule is on the page


def test_long_names_fold_at_separators_in_chromium(server, plan_ids, tmp_path):
    sync_api = needs_chromium()
    shot = tmp_path / "ui_plan_list.png"
    with sync_api.sync_playwright() as p:
        browser, page = chromium_page(p, height=900)
        try:
            sign_in(page, server)
            page.screenshot(path=str(shot), full_page=True)
            broken = page.evaluate(PIECES_BROKEN_JS, ONE_LINE_CHARS)
            cells = page.locator("#plans tbody td:nth-child(2)").count()
            scroll = page.evaluate("() => document.documentElement.scrollWidth")
        finally:
            browser.close()
    assert cells >= len(LONG_NAMES)
    # before: "lathe-22kW" (the machine) folded after its "-" as well
    assert broken == [], f"name pieces broken across lines: {broken}; screenshot {shot}"
    assert scroll <= 1280, f"the plan list scrolls sideways; screenshot {shot}"
