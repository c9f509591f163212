"""The plan list (``/ui/``) as a process engineer meets it, in Chromium at 1280 and 800 px.

An audit of the pages (2026-12-04) found the list's "Created" cell folding a date inside
itself ("2026-12-" over "04") at 1280 px, where the report's tables never do
(:func:`api.report.html_parts.timestamp_html`). Here a year's names besides: a 200-character
plan name, a machine named with umlauts and ``<script>``; the page must fit either window, break
no word inside a cell, run no script and escape every name, and its "Log out" must sign out.
The Chromium test skips, saying why, without Debian's chromium or the playwright package.
"""

from __future__ import annotations

import pytest
from test_report_layout import BROKEN_WORDS_JS, chromium_page, needs_chromium
from test_ui import sign_in

from conftest import demo_body

LONG_NAME = ("a-year-of-plans-" * 13)[:200]
MACHINE = "Drehmaschine-Überlänge-" * 4 + "<script>alert(1)</script>"


@pytest.fixture(scope="module")
def listed(sqlite_server):
    """Two plans: the demonstration part, and one with the long name on the odd machine."""
    with sqlite_server.client("engineer") as c:
        for name, machine in (("plain", None), (LONG_NAME, MACHINE)):
            body = demo_body()
            body["name"] = name
            if machine:
                body["machine"]["name"] = machine
            r = c.post("/plans", json=body)
            assert r.status_code == 201, r.text
    return sqlite_server


@pytest.mark.parametrize("width", [1280, 800])
def test_the_plan_list_fits_and_breaks_no_word(listed, width, tmp_path):
    sync_api = needs_chromium()
    shot = tmp_path / f"plans_{width}.png"
    with sync_api.sync_playwright() as p:
        browser, page = chromium_page(p)
        try:
            page.set_viewport_size({"width": width, "height": 800})
            errors: list[str] = []
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            sign_in(page, listed)
            page.screenshot(path=str(shot), full_page=True)
            scroll = page.evaluate("() => document.documentElement.scrollWidth")
            broken = page.evaluate(BROKEN_WORDS_JS, None)
            scripts = page.evaluate("() => document.querySelectorAll('script').length")
            text = page.inner_text("#plans")
            page.click("nav button[type=submit]")  # Log out
            page.wait_for_url(f"http://127.0.0.1:{listed.port}/ui/login")
            again = page.goto(f"http://127.0.0.1:{listed.port}/ui/")
            assert again is not None and again.url.endswith("/ui/login"), "still signed in"
        finally:
            browser.close()
    assert scroll <= width, f"the list scrolls sideways: {scroll} px; {shot}"
    assert broken == [], f"words broken across lines: {broken}; {shot}"
    assert scripts == 0 and "<script>alert(1)</script>" in text.replace("\n", "")
    assert errors == [], errors
