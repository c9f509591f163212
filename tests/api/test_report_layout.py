"""The report page as a reader sees it at 1280 px, in a real headless Chromium (issue 30).

A plan of the demonstration part with 30 parts from the virtual lathe (one rough-OD force
over the limit, as tests/api/test_report.py) is rendered with :func:`render_record` and shown
in Debian's Chromium at a 1280 x 800 viewport. No word of any table cell may break across
lines: each whitespace-separated word of each text node is a DOM Range whose client
rectangles must all lie on one line ("0.0529 / 2", "Ve rsi on" and "ro ug h- od" did before).
The same check run on a table squeezed with ``overflow-wrap: anywhere`` finds broken words,
so it can fail. Playwright waits on the page; nothing sleeps.

The Chromium tests need Debian's ``chromium`` and the ``playwright`` Python package (never a
downloaded browser); without either they skip, saying which is missing.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from report_support import stored_demo

from api.report.html import render_record
from api.services.read.record import report_record

PARTS = 30
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
VIEWPORT = {"width": 1280, "height": 800}
#: Playwright's bound on each wait [ms]: the pages answer in under a second (issue 30), so only
#: a hung server or browser reaches it; not Playwright's 30 s default, which a loaded host hit.
WAIT_BOUND_MS = 180_000

#: The words of every table cell (and caption) that span more than one line, with the cell.
BROKEN_WORDS_JS = """
(root) => {
  const broken = [];
  for (const cell of (root || document).querySelectorAll('th, td, caption')) {
    const walker = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    for (let node = walker.nextNode(); node; node = walker.nextNode()) {
      const words = /\\S+/g;
      let m;
      while ((m = words.exec(node.textContent)) !== null) {
        const range = document.createRange();
        range.setStart(node, m.index);
        range.setEnd(node, m.index + m[0].length);
        const lines = new Set([...range.getClientRects()]
          .filter(r => r.width > 0).map(r => Math.round(r.bottom)));
        if (lines.size > 1) broken.push([m[0], cell.textContent.trim().slice(0, 60)]);
      }
    }
  }
  return broken;
}
"""


#: The texts of the plots (labels, ticks, legends) that stick out of their SVG.
TEXT_OUTSIDE_SVG_JS = """
() => [...document.querySelectorAll('figure svg')].flatMap(svg => {
  const box = svg.getBoundingClientRect();
  return [...svg.querySelectorAll('text')].filter(t => {
    const r = t.getBoundingClientRect();
    return r.left < box.left - 0.5 || r.right > box.right + 0.5
        || r.top < box.top - 0.5 || r.bottom > box.bottom + 0.5;
  }).map(t => t.textContent);
})
"""


def chromium_page(playwright, height: int = VIEWPORT["height"]):
    """A browser (Debian's Chromium) and a page at a 1280 px wide viewport (800 high)."""
    browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
    context = browser.new_context(viewport={**VIEWPORT, "height": height})
    context.set_default_timeout(WAIT_BOUND_MS)  # only a hung browser reaches it
    return browser, context.new_page()


def needs_chromium():
    """playwright.sync_api, or skip saying what is missing."""
    if not CHROMIUM.is_file() or shutil.which(str(CHROMIUM)) is None:
        pytest.skip(f"{CHROMIUM} not installed (apt-get install chromium)")
    return pytest.importorskip(
        "playwright.sync_api", reason="the playwright Python package is not installed"
    )


@contextmanager
def shown(html: str, width: int = VIEWPORT["width"]) -> Iterator[Any]:
    """A Chromium page ``width`` px wide showing ``html`` (skips where Chromium is missing)."""
    sync_api = needs_chromium()
    with sync_api.sync_playwright() as p:
        browser, page = chromium_page(p)
        try:
            if width != VIEWPORT["width"]:
                page.set_viewport_size({**VIEWPORT, "width": width})
            page.set_content(html, wait_until="load")
            yield page
        finally:
            browser.close()


@pytest.fixture(scope="module")
def report_page(tmp_path_factory) -> str:
    _, engine, plan_id = stored_demo(tmp_path_factory.mktemp("layout"), PARTS)
    page = render_record(report_record(engine=engine, plan_id=plan_id))
    engine.dispose()
    return page


def test_no_word_breaks_inside_a_cell_at_1280(report_page, tmp_path):
    shot = tmp_path / "report_layout.png"  # for the failure's message
    with shown(report_page) as page:
        page.screenshot(path=str(shot), full_page=True)
        broken = page.evaluate(BROKEN_WORDS_JS, None)
        cells = page.evaluate("() => document.querySelectorAll('th, td').length")
        scroll = page.evaluate("() => document.documentElement.scrollWidth")
        limit = page.locator("#setpoints td", has_text="864,000").first.inner_text()
        outside = page.evaluate(TEXT_OUTSIDE_SVG_JS)
    assert cells > 400  # the check saw the tables (31 versions x 12 columns, setpoints ...)
    assert broken == [], f"words broken across lines: {broken}; screenshot {shot}"
    assert scroll <= VIEWPORT["width"]  # and the page still fits: nothing scrolls sideways
    assert limit == "864,000 (minimum)"  # never "(min)" beside a "Time [min]" column
    assert outside == [], f"plot text cut at the plot's edge: {outside}"


def test_the_check_finds_a_word_broken_inside(report_page):
    """The same check on the report's history table squeezed to 400 px with the old CSS."""
    squeezed = report_page.replace(
        "</style>",
        "#history { width: 400px; } #history * { overflow-wrap: anywhere; "
        "white-space: normal !important; }</style>",
        1,
    )
    with shown(squeezed) as page:
        broken = page.evaluate(BROKEN_WORDS_JS, None)
    words = {word for word, _ in broken}
    assert "Version" in words or "rough-grooves" in words, broken


def test_the_bands_plot_says_what_each_mark_is(report_page):
    """Legend entries in the bands SVG, and a caption explaining triangles above the line."""
    start = report_page.index('data-kind="bands" data-operation="rough-od"')
    figure = report_page[start : report_page.index("</figure>", start)]
    for entry in ("ΔY in force (the optimiser&#x27;s)", "next part", "ΔY after the part&#x27;s"):
        assert entry in figure, entry
    caption = figure[figure.index("<figcaption>") :]
    assert "Triangles: the band that part" in caption
    assert "A grey triangle above the line (RCB action hold)" in caption
