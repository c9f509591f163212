"""The report page (``rcb report``, and ``/ui/plans/{id}``) in an 800 px window, in Chromium.

An audit of the pages at 1280 and 800 px (2026-12-04) found that at 800 px the setpoints table
(10 columns, 977 px at its narrowest) and the history table of a plan with many versions
(1167 px) pushed the whole page sideways: the overview, the plots and the headings scrolled
with them. A wide table now scrolls in a box of its own (``div.wide``, focusable and named),
and the page never does. The page is the 30-part demonstration of
:mod:`test_report_layout`; the Chromium test skips, saying why, without Debian's chromium or
the playwright package.
"""

from __future__ import annotations

import pytest
from report_support import stored_demo
from test_report_layout import BROKEN_WORDS_JS, shown

from api.report.html import render_record
from api.services.read.record import report_record

NARROW = 800  # px: a laptop's half screen, a tablet

#: Per table: its id, its right edge, the overflow-x of its nearest scrolling box (or null)
#: and that box's right edge.
TABLES_JS = """
() => [...document.querySelectorAll('table')].map(t => {
  let box = t.parentElement;
  while (box && !['auto', 'scroll'].includes(getComputedStyle(box).overflowX))
    box = box.parentElement;
  return [t.id, t.getBoundingClientRect().right, box ? box.tagName : null,
          box ? box.getBoundingClientRect().right : null,
          box ? box.scrollWidth > box.clientWidth : false,
          box ? box.tabIndex : null, box ? box.getAttribute('aria-label') : null];
})
"""


@pytest.fixture(scope="module")
def report_page(tmp_path_factory) -> str:
    _, engine, plan_id = stored_demo(tmp_path_factory.mktemp("narrow"), 30)
    page = render_record(report_record(engine=engine, plan_id=plan_id))
    engine.dispose()
    return page


def test_a_wide_table_scrolls_in_its_own_box_at_800(report_page, tmp_path):
    shot = tmp_path / "report_800.png"
    with shown(report_page, NARROW) as page:
        page.screenshot(path=str(shot))
        scroll = page.evaluate("() => document.documentElement.scrollWidth")
        view = page.evaluate("() => window.innerWidth")
        tables = page.evaluate(TABLES_JS)
        broken = page.evaluate(BROKEN_WORDS_JS, None)
    assert view == NARROW
    assert scroll <= view, f"the page scrolls sideways: {scroll} px; {tables}; {shot}"
    assert {t[0] for t in tables} >= {"setpoints", "history"}, tables
    wide = [t for t in tables if t[1] > view]
    assert wide, f"no table is wider than {NARROW} px: the test tests nothing; {tables}"
    for name, _, box, box_right, scrolls, tab_index, label in wide:
        assert box == "DIV" and box_right <= view and scrolls, f"{name}: {tables}; {shot}"
        assert tab_index == 0 and label, f"{name}: a keyboard cannot scroll it; {tables}"
    # squeezed into the box, still no word broken inside a cell
    assert broken == [], f"words broken across lines: {broken}; {shot}"


def test_the_tables_still_fit_1280_without_scrolling(report_page):
    with shown(report_page) as page:
        tables = page.evaluate(TABLES_JS)
    assert [t for t in tables if t[4]] == [], f"a box scrolls at 1280 px: {tables}"
