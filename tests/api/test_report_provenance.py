"""Where a plan's models started from, as the report and ``rcb plans show`` say it, and the
next part's prediction in a new plan's outputs plot (a process engineer's review, 2026-12-02).

- A spread every quantity shares is one value (``4.1 %``), not ``4.1-4.1 %``.
- A plan from the catalogue says so in ``rcb plans show`` as the report does.
- The fleet prior's operations are in the plan's order, as in the setpoint table.
- A prior a part let go says why, in the words REST answers (``provenance.text``).
- A plan with no part draws the next part's prediction ± band in its outputs plot.
"""

from __future__ import annotations

import html
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_fleet_db import LEARN, _body, _learned
from test_fleet_let_go import _report

from api.cli.main import app
from api.report import plots
from api.report.chart import Chart, Panel
from api.report.provenance import prior_line, span
from api.report.series import Output
from api.report.svg import to_svg
from api.services.plans import create_plan
from api.services.read import get_plan
from db.engine import make_engine

from migrated import migrated

SVG = "{http://www.w3.org/2000/svg}"


def _line(quantity: str, machines: float, operations: float) -> dict[str, Any]:
    return {
        "quantity": quantity,
        "plans": ["fleet-a", "fleet-b"],
        "machines": ["lathe-0", "lathe-1"],
        "between_machine_spread": machines,
        "operation_spread": operations,
        "readings": 24,
        "widened_by_part": None,
        "text": f"{quantity}: prior from 2 plans on 2 machines",
    }


def _plan(*lines: dict[str, Any]) -> dict[str, Any]:
    operations = [{"name": "rough-od"}]
    return {"prior": "fleet", "operations": operations, "provenance": {"rough-od": list(lines)}}


def test_a_spread_every_quantity_shares_is_one_value() -> None:
    assert span([4.12, 4.08]) == "4.1"  # both read 4.1 at one decimal
    assert span([2.94, 3.16, 3.05]) == "2.9-3.2"
    same = prior_line(_plan(_line("force_N", 0.0412, 0.056), _line("roughness_um", 0.0408, 0.0558)))
    assert same.startswith(
        "the fleet: 2 plans on 2 machines, between-machine spread 4.1 %, between a machine's "
        "operations 5.6 % (rcb plans show"
    )
    apart = prior_line(_plan(_line("force_N", 0.029, 0.009), _line("roughness_um", 0.032, 0.01)))
    assert "between-machine spread 2.9-3.2 %, between a machine's operations 0.9-1.0 %" in apart
    one = _line("force_N", 0.05, 0.02) | {"plans": ["fleet-a"], "machines": ["lathe-0"]}
    assert prior_line(_plan(one)).startswith("the fleet: 1 plan on 1 machine, ")


def test_the_operations_the_fleet_did_not_measure_are_said_to_start_from_the_catalogue() -> None:
    """A review: the report said "Models started from the fleet" where one operation of six
    did; the others are named, in the plan's order, as starting from the catalogue."""
    plan = _plan(_line("force_N", 0.04, 0.02))
    plan["operations"] += [{"name": "finish-od"}, {"name": "finish-grooves"}]
    said = prior_line(plan)
    assert said.startswith("the fleet: 2 plans on 2 machines, ")
    assert said.endswith("; finish-od, finish-grooves from the tools' catalogue models")
    assert "catalogue" not in prior_line(_plan(_line("force_N", 0.04, 0.02)))


# --------------------------------------------------------------------------------------------
# the outputs plot of a plan with no part


def _output(parts: int) -> Output:
    """Force predicted 1401 ± 98.66 N at every setpoint, measured 1390 N on each part."""
    rows = parts + 1
    return Output(
        quantity="force_N",
        limit=2000.0,
        sense="max",
        predicted=np.full(rows, 1401.0),
        band=np.full(rows, 98.66),
        measured=np.append(np.full(parts, 1390.0), np.nan),
        uncertainty=np.append(np.full(parts, 3.0), np.nan),
        band_after=np.append(np.full(parts, 90.0), np.nan),
        flagged=np.zeros(rows, dtype=bool),
        checked=np.zeros(rows, dtype=bool),
        held=np.zeros(rows, dtype=bool),
        changed=np.zeros(rows, dtype=bool),
    )


def _drawn(parts: int) -> ET.Element:
    x = np.arange(1.0, parts + 2.0)
    marks = plots._output_marks(x, _output(parts))
    return ET.fromstring(to_svg(Chart("", plots.PART_AXIS, (Panel("force", marks),)), "p"))


def _value(root: ET.Element, y_px: float) -> float:
    """The value at pixel row ``y_px``, read off the y tick labels."""
    ticks = [
        (float(t.text.replace(",", "")), float(t.get("y")) - 3.5)
        for t in root.iter(f"{SVG}text")
        if t.get("text-anchor") == "end" and t.text
    ]
    values, ys = zip(*ticks, strict=True)
    return float(np.interp(y_px, ys[::-1], values[::-1]))  # y grows downwards


@pytest.mark.parametrize("parts", [0, 4])
def test_the_next_parts_prediction_and_band_are_drawn(parts: int) -> None:
    """0 parts: an open marker at 1401 N with a bar 1302.3-1499.7 N, no empty band or line
    in the legend; 4 parts: the same at part 5, the shaded band as before."""
    root = _drawn(parts)
    opened = [p for p in root.iter(f"{SVG}polyline") if "mk-open" in p.get("marker-end", "")]
    (point,) = [p.get("points") for p in opened]
    x_px, y_px = (float(v) for v in point.split(","))
    assert_allclose(_value(root, y_px), 1401.0, atol=1.0)  # 0.1 px of 140 px over ~700 N
    bars = [p.get("d") for p in root.iter(f"{SVG}path") if p.get("stroke") == plots.SETPOINT]
    next_bar = [d for d in bars if d.startswith(f"M{x_px:g} ") and "V" in d]
    (bar,) = next_bar
    low_px, high_px = (
        float(v) for v in re.fullmatch(r"M[0-9.]+ ([0-9.]+)V([0-9.]+)", bar).groups()
    )
    assert_allclose([_value(root, low_px), _value(root, high_px)], [1302.34, 1499.66], atol=1.0)
    legend = [t.text for t in root.iter(f"{SVG}text") if t.get("text-anchor") == "start"]
    assert "next part: predicted ± band" in legend
    assert ("predicted ± band" in legend) == (parts > 0)
    assert ("predicted" in legend) == (parts > 0)
    shaded = [p for p in root.iter(f"{SVG}path") if p.get("fill-opacity") == "0.2"]
    assert len(shaded) == (1 if parts else 0)


# --------------------------------------------------------------------------------------------
# a fleet: two machines learned; fleet-c from the fleet, its part c-1 reading roughness
# at 0.85 x (its roughness priors and its roughness chain's noise prior let go); fleet-d from
# the catalogue


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, dict[str, Any], Path]:
    folder = tmp_path_factory.mktemp("fleet")
    url = f"sqlite:///{folder / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    try:
        _learned(engine, "fleet-a", 0, 12)
        _learned(engine, "fleet-b", 1, 12)
        made = create_plan(engine=engine, body=_body("fleet-c", "lathe-3"), settings=LEARN)
        _report(engine, int(made.body["id"]), "c-1", 0.85)
        create_plan(
            engine=engine, body=_body("fleet-d", "lathe-4"), settings=LEARN, prior="catalogue"
        )
        answer = get_plan(engine=engine, plan_id=int(made.body["id"]))
    finally:
        engine.dispose()
    return url, answer, folder


def _reason(line: dict[str, Any], serial: str) -> str:
    """What REST's text says after ``let go by part SERIAL:``."""
    _, found, reason = line["text"].partition(f"; let go by part {serial}: ")
    assert found, line["text"]
    return reason


def _flat(text: str) -> str:
    return " ".join(text.split())


def _show(runner: Any, url: str, plan: str) -> str:
    shown = runner.invoke(app, ["plans", "show", plan, "--db", url], env={"COLUMNS": "80"})
    assert shown.exit_code == 0, shown.output
    assert [line for line in shown.output.splitlines() if len(line) > 80] == []
    return str(shown.output)


def test_plans_show_lists_the_fleet_prior_in_the_plans_order_with_reasons(
    fleet: tuple[str, dict[str, Any], Path], runner: Any
) -> None:
    url, answer, _ = fleet
    order = [op["name"] for op in answer["operations"]]
    assert sorted(order) != order  # alphabetical order would show here
    shown = _show(runner, url, "fleet-c")
    table = shown.split("learn's fleet prior")[1].split("learn's noise prior")[0]
    listed = [w for line in table.splitlines() for w in line.split()[:1] if w in order]
    assert listed == order
    models = [p for ps in answer["provenance"].values() for p in ps if p["widened_by_part"]]
    chains = [p for p in answer["noise_provenance"] if p["let_go_by_part"]]
    assert {p["quantity"] for p in models} == {"roughness_um"} and len(models) >= 2
    assert [p["quantity"] for p in chains] == ["roughness_um"]
    outside = _reason(models[0], "c-1")
    assert outside.startswith("this machine lies outside the fleet's spread")
    noisier = _reason(chains[0], "c-1")
    assert noisier.startswith("this machine's chain reads noisier than the fleet's")
    flat = _flat(shown)
    assert flat.count(f"let go by part c-1: {outside}") == 1  # once, under the fleet table
    assert flat.count(f"let go by part c-1: {noisier}") == 1  # once, under the noise table
    assert "models started from" not in shown


def test_plans_show_says_a_plan_started_from_the_catalogue(
    fleet: tuple[str, dict[str, Any], Path], runner: Any
) -> None:
    url, _, _ = fleet
    shown = _show(runner, url, "fleet-d")
    assert "rcb: models started from the tools' catalogue models\n" in shown
    assert "learn's fleet prior" not in shown


def _overview_prior(page: str, raw: bool = False) -> str:
    """The "Models started from" entry's text (``raw``: its markup)."""
    found = re.search(r"<dt>Models started from</dt><dd>(.*?)</dd>", page, re.S)
    assert found, "no Models started from"
    return found.group(1) if raw else html.unescape(re.sub(r"<[^>]+>", "", found.group(1)))


def _page(runner: Any, url: str, folder: Path, plan: str) -> str:
    """``rcb report PLAN --out FOLDER/PLAN.html`` (it must succeed): the page."""
    page = folder / f"{plan}.html"
    done = runner.invoke(app, ["report", plan, "--db", url, "--out", str(page)])
    assert done.exit_code == 0, done.output
    return page.read_text(encoding="utf-8")


def test_the_report_says_why_each_prior_was_let_go_in_the_plans_order(
    fleet: tuple[str, dict[str, Any], Path], runner: Any
) -> None:
    url, answer, folder = fleet
    text = _page(runner, url, folder, "fleet-c")
    said, markup = _overview_prior(text), _overview_prior(text, raw=True)
    # an operation's name and a serial never break at their hyphen (a 1280 px window wraps)
    assert '<span class="nw">finish-contour</span> roughness_um' in markup
    assert 'by part <span class="nw">c-1</span>:' in markup
    let_go = [
        f"{op} {p['quantity']}"
        for op in (o["name"] for o in answer["operations"])
        for p in answer["provenance"].get(op, [])
        if p["widened_by_part"] == "c-1"
    ]
    model = next(p for ps in answer["provenance"].values() for p in ps if p["widened_by_part"])
    chain = next(p for p in answer["noise_provenance"] if p["let_go_by_part"])
    assert f"; {', '.join(let_go)} let go by part c-1: {_reason(model, 'c-1')}" in said
    assert f"; roughness_um noise let go by part c-1: {_reason(chain, 'c-1')}" in said
    lines = [p for ps in answer["provenance"].values() for p in ps]
    spreads = sorted({f"{100 * p['between_machine_spread']:.1f}" for p in lines}, key=float)
    shown = spreads[0] if len(spreads) == 1 else f"{spreads[0]}-{spreads[-1]}"
    assert f"the fleet: 2 plans on 2 machines, between-machine spread {shown} %" in said


def test_a_new_plans_report_shows_its_next_part_in_the_outputs(
    fleet: tuple[str, dict[str, Any], Path], runner: Any
) -> None:
    url, _, folder = fleet
    text = _page(runner, url, folder, "fleet-d")
    assert _overview_prior(text) == "the tools' catalogue models"
    figure = text.split('data-kind="outputs" data-operation="rough-od">')[1].split("</figure>")[0]
    # force, roughness and tool life: each its next part's marker and bar, no empty band
    assert figure.count("next part: predicted ± band") == 3
    assert figure.count('fill-opacity="0.2"') == 0
    assert figure.count('marker-end="url(#op1-outputs-mk-open-1f77b4)"') == 3


def test_plans_show_names_the_operations_that_start_from_the_catalogue(
    fleet: tuple[str, dict[str, Any], Path], runner: Any, tmp_path: Path
) -> None:
    """A review: a plant that imported one insert's models saw its one operation's fleet prior
    and nothing of the five that start from the catalogue."""
    from api.services.fleet_models import export_tool, import_tool

    url, _, _ = fleet
    first, second = make_engine(url), f"sqlite:///{tmp_path / 'plant2.db'}"
    migrated(second)
    engine = make_engine(second)
    try:
        import_tool(
            engine=engine, data=export_tool(engine=first, tool="CNMG432RN"), source="cnmg.json"
        )
        made = create_plan(engine=engine, body=_body("one-insert", "lathe-9"), settings=LEARN)
    finally:
        first.dispose()
        engine.dispose()
    assert list(made.body["provenance"]) == ["rough-od"]
    rest = [op["name"] for op in made.body["operations"]][1:]
    flat = _flat(_show(runner, second, "one-insert"))
    assert f"rcb: {', '.join(rest)}: from the tools' catalogue models" in flat
