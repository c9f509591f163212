"""rcb report: the HTML record of a plan (api/report/html.py, api/report/plots.py,
api/report/svg.py, api/cli/html_report.py).

A plan of the demonstration part (Ivester & Heigel) with 10 parts from the virtual lathe in a
temporary SQLite database; part SN-0004 reports a rough-OD force over the 2000 N limit, which
RCB must flag. The page is checked as XML (it is written to be well-formed) and its tables
against the stored numbers; the limit lines and flags against the figures' artists. The
command, rcb report, is checked in test_report_cli.py; the plan and its page are made by
tests/report_support.py.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from html.parser import HTMLParser

import pytest
from numpy.testing import assert_allclose
from report_support import OVER_LIMIT, PARTS, record_page, stored_record

from api.report import plots
from api.report.html import render_html_report as render_report
from api.report.series import operation_series
from api.report.svg import render


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    return stored_record(tmp_path_factory)


@pytest.fixture(scope="module")
def page(stored):
    return record_page(stored)


KINDS = ("parameters", "outputs", "bands", "productivity")
#: The XML namespace names inline SVG declares: identifiers, never fetched.
SVG_NAMESPACES = {"http://www.w3.org/2000/svg", "http://www.w3.org/1999/xlink"}


def _xml(text):
    return ET.fromstring(text.removeprefix("<!DOCTYPE html>\n"))


def _text(element):
    return "".join(element.itertext()).strip()


def _local(tag):
    return tag.rsplit("}", 1)[-1]


def _table(root, table_id):
    table = root.find(f".//table[@id='{table_id}']")
    assert table is not None, f"no table {table_id}"
    return table


# --------------------------------------------------------------------------------------------
# the page


def test_page_is_well_formed_html_and_xml(page):
    root = _xml(page)  # raises on any unbalanced tag or unescaped & and <
    assert root.tag == "html"
    assert root.find("head/meta[@charset='utf-8']") is not None

    class Balanced(HTMLParser):
        void = {"meta", "br", "hr", "img", "input", "link", "wbr"}

        def __init__(self):
            super().__init__()
            self.stack = []

        def handle_starttag(self, tag, attrs):
            if tag not in self.void:
                self.stack.append(tag)

        def handle_startendtag(self, tag, attrs):
            pass

        def handle_endtag(self, tag):
            assert self.stack and self.stack.pop() == tag, tag

    parser = Balanced()
    parser.feed(page)
    parser.close()
    assert parser.stack == []


def test_page_loads_nothing_from_elsewhere(page):
    # Every URI in the page is an SVG namespace name, and only in an xmlns declaration.
    uris = re.findall(r"[A-Za-z][A-Za-z0-9+.-]*://[^\s\"'<>)]*", page)
    assert uris and set(uris) <= SVG_NAMESPACES
    declared = re.findall(r'xmlns(?::xlink)?="([^"]*)"', page)
    assert sorted(uris) == sorted(declared)
    assert not re.search(r"<(script|link|img|iframe|object|embed|image)\b", page, re.I)
    assert not re.search(r"\bsrc\s*=|@import|\bon[a-z]+\s*=", page, re.I)
    # references: every href and url() points at an id in the page itself, ids are unique
    ids = re.findall(r'\bid="([^"]*)"', page)
    assert len(ids) == len(set(ids))
    hrefs = re.findall(r'href="([^"]*)"', page)
    urls = re.findall(r"url\(([^)]*)\)", page)
    assert hrefs and urls
    assert all(ref.startswith("#") and ref[1:] in ids for ref in hrefs + urls)


def test_one_svg_per_plot_kind_per_operation(stored, page):
    _, _, plan, _, _ = stored
    root = _xml(page)
    figures = root.findall(".//figure")
    shown = [(f.get("data-operation"), f.get("data-kind")) for f in figures]
    names = [op["name"] for op in plan["operations"]]
    assert len(names) == 6
    assert shown == [(None, "cycle"), *((n, k) for n in names for k in KINDS)]
    for figure in figures:
        svgs = [e for e in figure.iter() if _local(e.tag) == "svg"]
        assert len(svgs) == 1 and svgs[0].tag == "{http://www.w3.org/2000/svg}svg"


def test_history_table_holds_the_stored_numbers(stored, page):
    _, _, _, history, _ = stored
    table = _table(_xml(page), "history")
    names = [_text(th) for th in table.findall("thead/tr")[1].findall("th")]
    rows = table.findall("tbody/tr")
    assert len(rows) == len(history["versions"]) == PARTS + 1
    for row, version in zip(rows, history["versions"], strict=True):
        cells = [_text(td) for td in row.findall("td")]
        assert int(cells[0]) == version["version"]
        assert cells[1] == version["cause"]
        assert cells[2] == (version["serial"] or "–")
        # shown with 4 significant digits
        assert_allclose(float(cells[4]), version["cycle_time_min"], rtol=5e-4)
        stored_mrr = {op["name"]: op["mrr_cm3_min"] for op in version["operations"]}
        shown_mrr = dict(zip(names, (float(c) for c in cells[5 : 5 + len(names)]), strict=True))
        assert_allclose([shown_mrr[n] for n in names], [stored_mrr[n] for n in names], rtol=5e-4)
    first = dict(zip(names, (_text(td) for td in rows[0].findall("td")[5:]), strict=False))
    assert_allclose(
        float(first["rough-od"]), 191.2, rtol=0.005
    )  # Ivester & Heigel Table 5 step 1 R


def test_history_headers_say_what_they_head(stored, page):
    """Its header has two rows (MRR over one column per operation): each ``th`` says it heads
    the columns under it (``scope="col"``, WCAG technique H63), so a screen reader names a cell
    "MRR, rough-od" (a review at 1280 px found none)."""
    table = _table(_xml(page), "history")
    heads = [th for tr in table.findall("thead/tr") for th in tr.findall("th")]
    assert len(heads) == 7 + 6  # 7 over two rows, one per operation
    assert [th.get("scope") for th in heads] == ["col"] * len(heads)


def test_setpoints_table_shows_the_setpoints_in_force(stored, page):
    _, _, plan, history, _ = stored
    table = _table(_xml(page), "setpoints")
    current = {op["name"]: op for op in history["versions"][-1]["operations"]}
    rows = table.findall("tbody/tr")
    assert {r.get("data-operation") for r in rows} == set(current)
    for row in rows:
        op = current[row.get("data-operation")]
        cells = [_text(td) for td in row.findall("td")]
        if len(cells) == 10:  # first row of an operation: setpoint, MRR, time, binding
            assert_allclose(float(cells[2]), op["mrr_cm3_min"], rtol=5e-4)
            assert_allclose(float(cells[3]), op["time_min"], rtol=5e-4)
            shown = dict(re.findall(r"\b([dfv]) = ([0-9.]+)", cells[1]))
            assert_allclose(float(shown["f"]), op["setpoint"]["feed_mm_rev"], rtol=5e-4)
        quantity = {"force F [N]": "force_N", "roughness Ra [µm]": "roughness_um"}.get(cells[-5])
        if quantity:
            value, band = re.findall(r"[0-9.,]+", cells[-4])[:2]
            assert_allclose(float(value), op["predicted"][quantity]["value"], rtol=5e-4)
            assert_allclose(float(band), op["predicted"][quantity]["band"], rtol=5e-4)
    # rough OD: force and roughness bind at the robust optimum, so their margin is 0 there; at
    # its grid point (0.001 mm, 0.0001 mm/rev) just above: one feed step of 0.32 mm/rev moves
    # the force 0.025 % and Ra 0.04 %, so under 0.05 % of the 2000 N and 4.0 µm limits
    rough = [r for r in rows if r.get("data-operation") == "rough-od"]
    margins = {_text(r.findall("td")[-5]): _text(r.findall("td")[-2]) for r in rough}
    assert 0 < float(margins["force F [N]"]) < 0.0005 * 2000
    assert 0 < float(margins["roughness Ra [µm]"]) < 0.0005 * 4.0


def test_page_is_deterministic(stored, page):
    _, _, plan, history, parts = stored
    assert render_report(plan, history, parts) == page


# --------------------------------------------------------------------------------------------
# the plots


def test_limit_lines_are_at_the_plan_limits(stored, page):
    _, _, plan, history, parts = stored
    for index, op in enumerate(plan["operations"], start=1):
        series = operation_series(plan, history, parts, op["name"])
        expected = {q: v for q, v in op["limits"].items() if q != "parts_per_edge"}
        if "parts_per_edge" in op["limits"]:  # a minimum tool life: parts x volume [mm³]
            expected["tool_life_mm3"] = op["limits"]["parts_per_edge"] * op["volume_mm3"]
        limits = {o.quantity: o.limit for o in series.outputs}
        assert limits == pytest.approx(expected)
        # the drawn lines: one horizontal line per limit, at the limit
        figure = plots.outputs_figure(series)
        lines = {
            mark.gid: mark
            for panel in figure.panels
            for mark in panel.marks
            if (mark.gid or "").startswith("limit-")
        }
        assert set(lines) == {f"limit-{q}" for q in expected}
        for quantity, limit in expected.items():
            assert lines[f"limit-{quantity}"].kind == "hline"
            assert_allclose(lines[f"limit-{quantity}"].y, [limit])
            # and in the page: the line's group, and its legend entry with the value
            assert f'id="op{index}-outputs-limit-{quantity}"' in page
    # rough-od; "min" would read as minutes beside a time
    assert "limit (maximum) 2000 N" in page and "limit (minimum) 864,000 mm³" in page


def test_over_limit_part_is_flagged_and_marked(stored, page):
    _, _, plan, history, parts = stored
    assert parts[OVER_LIMIT]["operations"][0]["measurements"]["force_N"]["value"] == 2100.0
    series = operation_series(plan, history, parts, "rough-od")
    force = next(o for o in series.outputs if o.quantity == "force_N")
    assert force.flagged[OVER_LIMIT] and force.measured[OVER_LIMIT] == 2100.0
    assert len(force.flagged) == PARTS + 1 and not force.flagged[-1]  # the next part: no data
    figure = plots.outputs_figure(series)
    marks = [mark for mark in figure.panels[0].marks if mark.label == "flagged"]
    assert len(marks) == 1 and list(marks[0].x) == [OVER_LIMIT + 1]  # x: part number
    assert list(marks[0].y) == [2100.0]
    # the history row of the version SN-0004 caused
    rows = _table(_xml(page), "history").findall("tbody/tr")
    row = next(r for r in rows if _text(r.findall("td")[2]) == f"SN-{OVER_LIMIT + 1:04d}")
    marks = _text(row.findall("td")[-1])
    classes = row.get("class").split()
    assert classes[0] == "flagged" and "breach" in classes and "rough-od force_N" in marks
    assert "rough-od force_N BREACH" in marks  # a breach, told apart at a glance


def test_series_follow_the_setpoint_each_part_was_made_with(stored):
    _, _, plan, history, parts = stored
    series = operation_series(plan, history, parts, "rough-od")
    versions = {v["version"]: v["operations"][0] for v in history["versions"]}
    made_with = [versions[p["setpoint_version"]] for p in parts] + [versions[max(versions)]]
    assert series.versions == (*(p["setpoint_version"] for p in parts), max(versions))
    assert_allclose(
        series.parameters["feed_mm_rev"], [v["setpoint"]["feed_mm_rev"] for v in made_with]
    )
    assert_allclose(series.mrr_cm3_min, [v["mrr_cm3_min"] for v in made_with])
    force = next(o for o in series.outputs if o.quantity == "force_N")
    assert_allclose(force.band, [v["predicted"]["force_N"]["band"] for v in made_with])
    decided = [
        next(d for d in p["updates"] if (d["operation"], d["quantity"]) == ("rough-od", "force_N"))
        for p in parts
    ]
    assert_allclose(force.band_after[:-1], [d["band_after"] for d in decided])
    # held: the update kept the band in force although the one it computed is wider
    held = [d["action"] == "hold" and d["band_after"] > d["band_before"] for d in decided]
    assert force.held.tolist() == [*held, False] and any(held)  # learn, from few parts
    assert list(series.parameters) == ["depth_mm", "feed_mm_rev", "speed_m_min"]


def test_text_from_the_database_is_escaped(stored):
    _, _, plan, history, parts = stored
    odd = 'r<o>&"d $x^2$'

    def rename(value):
        if isinstance(value, dict):
            return {k: rename(v) for k, v in value.items()}
        if isinstance(value, list):
            return [rename(v) for v in value]
        return odd if value == "rough-od" else value

    plan = {**rename(plan), "name": "<script>alert(1)</script>"}
    plan["operations"] = plan["operations"][:1]  # one operation is enough (and faster)
    text = render_report(plan, rename(history), rename(parts))
    root = _xml(text)
    assert "<script" not in text and "<o>" not in text
    assert _text(root.find("head/title")) == "rcb report: plan <script>alert(1)</script> (id 1)"
    # the name is shown as given, also inside the plots (no TeX: $x^2$ stays as written)
    sections = [s for s in root.findall(".//section") if s.get("data-operation") == odd]
    assert len(sections) == 1
    svg_text = [_text(e) for e in sections[0].iter() if _local(e.tag) == "text"]
    assert f"{odd}: constrained outputs" in svg_text


def test_a_plan_without_parts_shows_its_start(stored):
    _, _, plan, history, _ = stored
    start_only = {**history, "versions": history["versions"][:1]}
    root = _xml(render_report(plan, start_only, []))
    assert len(root.findall(".//figure")) == 1 + 6 * len(KINDS)
    assert len(_table(root, "history").findall("tbody/tr")) == 1


def test_last_parts_keep_their_numbers(stored):
    _, _, plan, history, parts = stored
    series = operation_series(plan, history, parts[-3:], "rough-od", first_part=PARTS - 2)
    line = plots.parameters_figure(series).panels[0].marks[0]
    assert_allclose(line.x, [PARTS - 2, PARTS - 1, PARTS, PARTS + 1])
    text = render_report(plan, history, parts, last=3)
    root = _xml(text)
    overview = dict(zip(map(_text, root.iter("dt")), map(_text, root.iter("dd")), strict=True))
    assert overview["Plotted"] == f"the last 3 parts, from SN-{PARTS - 2:04d}"
    assert overview["Parts reported"].startswith(f"{PARTS},")
    # the tables still hold every part's version and every flag
    assert len(_table(root, "history").findall("tbody/tr")) == PARTS + 1
    assert "rough-od force_N" in text
    with pytest.raises(ValueError, match="last"):
        render_report(plan, history, parts, last=0)


def test_svg_ids_are_prefixed_and_checked(stored):
    _, _, plan, history, parts = stored
    series = operation_series(plan, history, parts, "rough-od")
    svg = render(plots.parameters_figure, series, "p1")
    assert svg.startswith("<svg") and "<!DOCTYPE" not in svg
    assert all(i.startswith("p1-") for i in re.findall(r'\bid="([^"]*)"', svg))
    with pytest.raises(ValueError, match="id_prefix"):
        render(plots.parameters_figure, series, 'x" onload="')
