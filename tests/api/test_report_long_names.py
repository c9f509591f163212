"""A plant's page at 1280 px: long plan, machine, operation and tool names, long serials.

The demonstration plan is stored under a 90-character name on a 50-character machine, its six
operations renamed to 50 characters, and 205 parts with 43-character serials are reported
(bayes: a setpoint version a part, so the history table lists 200 versions and summarises
the rest). Before, the history table's operation headers and serials never broke: the page
was 3162 px wide at a 1280 px window, and squeezed dates broke inside ("2026-12-" / "04").
Now a name or serial longer than 24 characters breaks only between its pieces, dates and
times never; the page fits and no word breaks inside (the check of test_report_layout).

In Debian's headless Chromium (never a downloaded browser); without it, or without the
playwright package, the Chromium tests skip, saying which is missing.
"""

from __future__ import annotations

import re

import pytest
from report_support import BODY
from test_report_layout import BROKEN_WORDS_JS, TEXT_OUTSIDE_SVG_JS, shown

from api.report.html import render_record
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read.record import HISTORY_ROWS, report_record
from api.services.read.setpoints import current_setpoints
from db.engine import make_engine

from conftest import report_at
from migrated import migrated

NAME = "customer-4711-hydraulic-cylinder-piston-rod-end-fitting-revision-C-second-setup-long"
MACHINE = "okuma-genos-l3000-e-mw-cell-7-bay-north-22kW-lathe"
SUFFIX = "-with-extended-descriptive-operation-name"
SERIAL = "SERIAL-LONG-CUSTOMER-4711-LOT-2026-11-{:05d}"
PARTS = HISTORY_ROWS + 5  # older versions summarised: the summary row is shown too
#: The parts' readings as fractions of the predictions, in turn: some below the band (a note).
READINGS = (0.99, 0.9, 1.0)
#: The WCAG 2.1 AA contrast of normal text (the marks are 12 px bold: not large text).
AA_CONTRAST = 4.5


def _long_body() -> dict:
    body = {**BODY, "name": NAME, "machine": {**BODY["machine"], "name": MACHINE}}
    body["operations"] = [{**op, "name": op["name"] + SUFFIX} for op in BODY["operations"]]
    return {**body, "rcb": {"strategy": "bayes"}}


def _report(engine, plan_id: int, serial: str, fraction: float) -> None:
    body = report_at(serial, current_setpoints(engine=engine, plan_id=plan_id), fraction=fraction)
    report_part(engine=engine, plan_id=plan_id, report=parse_report(body))


@pytest.fixture(scope="module")
def long_page(tmp_path_factory) -> str:
    url = f"sqlite:///{tmp_path_factory.mktemp('long') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    try:
        plan_id = create_plan(engine=engine, body=_long_body()).body["id"]
        for i in range(PARTS):
            _report(engine, plan_id, SERIAL.format(i), READINGS[i % len(READINGS)])
        return render_record(report_record(engine=engine, plan_id=plan_id))
    finally:
        engine.dispose()


#: The page's width, each table's and each heading's, and what sticks out of the window.
WIDTHS_JS = """
() => ({doc: document.documentElement.scrollWidth,
        view: document.documentElement.clientWidth,
        wide: [...document.querySelectorAll('table, h1, dl, figure')]
          .filter(e => e.scrollWidth > e.clientWidth + 1
                       || e.getBoundingClientRect().right > document.documentElement.clientWidth)
          .map(e => [e.tagName, e.id, e.scrollWidth, e.clientWidth])})
"""


def test_long_names_and_serials_fit_1280_without_breaking_a_word(long_page, tmp_path):
    assert "summary" in long_page and NAME in long_page  # the summarised versions are shown
    assert "below band" in long_page  # the marks name the operations too
    shot = tmp_path / "long_names.png"
    with shown(long_page) as page:
        page.screenshot(path=str(shot), full_page=True)
        widths = page.evaluate(WIDTHS_JS)
        broken = page.evaluate(BROKEN_WORDS_JS, None)
        outside = page.evaluate(TEXT_OUTSIDE_SVG_JS)
        header = page.locator("#history th.name").first.inner_text()
    assert widths["doc"] <= widths["view"] and widths["wide"] == [], f"{widths}; {shot}"
    assert broken == [], f"words broken across lines: {broken[:10]}; {shot}"
    assert outside == [], f"plot text cut at the plot's edge: {outside}"
    # the name reads whole (no character added, none lost), on a few lines
    assert re.sub(r"\s", "", header) == "rough-od" + SUFFIX


def test_every_plot_is_a_named_image(long_page):
    """Each SVG (role img) has an accessible name: a screen reader announces what it shows."""
    with shown(long_page) as page:
        images = page.get_by_role("img").count()
        named = page.get_by_role("img", name=re.compile(r"\S")).count()
        outputs = page.get_by_role("img", name=re.compile("constrained outputs")).count()
    assert images == 1 + 4 * len(BODY["operations"])  # the cycle plot, 4 per operation
    assert named == images
    assert outputs == len(BODY["operations"])


#: Each mark's colour against the background it is shown on, as Chromium computes both.
CONTRAST_JS = """
() => {
  const lum = c => {
    const [r, g, b] = c.match(/[0-9.]+/g).slice(0, 3).map(v => {
      v = Number(v) / 255;
      return v <= 0.03928 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4;
    });
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
  };
  const background = e => {
    for (; e; e = e.parentElement) {
      const c = getComputedStyle(e).backgroundColor;
      if (c !== 'rgba(0, 0, 0, 0)' && c !== 'transparent') return c;
    }
    return 'rgb(255, 255, 255)';
  };
  const probe = document.createElement('table');
  probe.innerHTML = ['', 'flagged', 'check', 'flagged check'].map(row =>
    `<tr class="${row}"><td>${['breach', 'above-band', 'below-band', 'note', 'check']
      .map(k => `<span class="${k}">x</span>`).join(' ')}</td></tr>`).join('');
  document.body.appendChild(probe);
  return [...probe.querySelectorAll('span')].map(s => {
    const [a, b] = [lum(getComputedStyle(s).color), lum(background(s))];
    const ratio = (Math.max(a, b) + 0.05) / (Math.min(a, b) + 0.05);
    return [s.parentElement.parentElement.className, s.className, ratio];
  });
}
"""


def test_flag_and_note_colours_have_aa_contrast(long_page):
    """Every mark's text on every row it may sit in: at least 4.5:1 (#c50 on white was 4.3)."""
    with shown(long_page) as page:
        ratios = page.evaluate(CONTRAST_JS)
    assert len(ratios) == 4 * 5
    low = [(row, kind, round(ratio, 2)) for row, kind, ratio in ratios if ratio < AA_CONTRAST]
    assert low == [], f"text below {AA_CONTRAST}:1 contrast: {low}"
