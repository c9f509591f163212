"""The HTML helpers the HTML report and the web view share (api/report/html_parts.py), and the
layout of api/cli and api/report: one home for the helpers, small modules, report apart from cli.
"""

from __future__ import annotations

import ast
import xml.etree.ElementTree as ET
from datetime import UTC, datetime
from pathlib import Path

from api.report.html_parts import (
    ONE_LINE_CHARS,
    PIECE_CHARS,
    document,
    escaped,
    name_html,
    row,
    tag,
    td,
    th,
    timestamp,
    timestamp_html,
)

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = (ROOT / "api" / "cli", ROOT / "api" / "report")
#: The largest module the layout allows (issue 16) [lines].
MAX_LINES = 400


def test_escaped_escapes_markup_and_both_quotes():
    expected = "&lt;a href=&quot;x&quot;&gt;&#x27;&amp;&#x27;&lt;/a&gt;"
    assert escaped("<a href=\"x\">'&'</a>") == expected
    assert escaped(1.5) == "1.5"


def test_tag_writes_attributes_dashed_escaped_and_skips_none():
    text = tag("td", "x", class_="num", data_operation='a"b', rowspan=None)
    assert text == '<td class="num" data-operation="a&quot;b">x</td>'


def test_cells_and_rows_escape_their_text():
    assert th("a<b") == "<th>a&lt;b</th>"
    assert td(3, class_="num") == '<td class="num">3</td>'
    assert row([td("x"), td("y")], data_plan=2) == '<tr data-plan="2"><td>x</td><td>y</td></tr>'


def test_timestamp_prints_a_datetime_to_the_second_and_anything_else_as_str():
    assert timestamp(datetime(2026, 1, 31, 12, 0, 5, 999, tzinfo=UTC)) == "2026-01-31 12:00:05 UTC"
    assert timestamp(datetime(2026, 1, 31, 12, 0, 5)) == "2026-01-31 12:00:05"
    assert timestamp("yesterday") == "yesterday"


def test_a_short_name_never_breaks_and_a_long_one_only_between_pieces():
    assert name_html("rough-od") == '<span class="nw">rough-od</span>'
    serial = "SERIAL-LONG-CUSTOMER-4711-LOT-2026-11-00012"
    html = name_html(serial)
    assert html == (
        '<span class="brk"><span class="nw">SERIAL-LONG-</span><wbr/>CUSTOMER-<wbr/>'
        '<span class="nw">4711-LOT-</span><wbr/><span class="nw">2026-11-</span><wbr/>00012</span>'
    )
    for name in (serial, "x" * 200, "<a>&" * 30, "a b-c_d/e.f" * 5):
        html = name_html(name)
        root = ET.fromstring(html)  # well-formed: escaped, the breaks empty elements
        assert "".join(root.itertext()) == name  # nothing added, nothing lost
        pieces = html.removeprefix('<span class="brk">').removesuffix("</span>").split("<wbr/>")
        texts = ["".join(ET.fromstring(f"<p>{p}</p>").itertext()) for p in pieces]
        assert max(map(len, texts)) <= PIECE_CHARS < ONE_LINE_CHARS < len(name)


def test_timestamp_html_keeps_the_date_and_the_time_each_whole():
    html = timestamp_html(datetime(2026, 12, 4, 3, 48, 10, tzinfo=UTC))
    assert html == '<span class="nw">2026-12-04</span> <span class="nw">03:48:10 UTC</span>'


def test_document_is_well_formed_xml_with_the_title_escaped():
    page = document("a < b", "p { color: red; }", tag("p", escaped("x & y")))
    assert page.startswith('<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"/>')
    root = ET.fromstring(page.removeprefix("<!DOCTYPE html>\n"))
    assert root.find("head/title").text == "a < b"
    assert root.find("body/p").text == "x & y"


def _modules():
    for package in PACKAGES:
        yield from sorted(package.glob("*.py"))


def test_one_set_of_html_helpers():
    """No module but html_parts defines an escaping or element helper of its own."""
    helpers = {"_e", "_tag", "_row", "_th", "_td", "_when", "escaped", "tag", "document"}
    for path in _modules():
        if path.name == "html_parts.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        assert not defined & helpers, f"{path.relative_to(ROOT)} defines {defined & helpers}"


def test_no_module_over_400_lines():
    for path in _modules():
        lines = len(path.read_text(encoding="utf-8").splitlines())
        assert lines <= MAX_LINES, f"{path.relative_to(ROOT)}: {lines} lines"


def test_report_does_not_import_the_cli():
    """api/report serves the CLI and the web view alike; it imports nothing from api/cli."""
    for path in sorted((ROOT / "api" / "report").glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("api.cli"), path.name
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("api.cli") for a in node.names), path.name
