"""Listings at 80 columns with a 60-character plan name and a 47-character tool name.

Before: a name holding a digit (``...-lot-07``) was kept whole as if a number, so every other
column was folded to its numbers: ``rcb fleet show TOOL`` folded its headings and ``no: no
part reported yet`` one letter a line, the name whole in 60 columns.
"""

from __future__ import annotations

import pytest
from test_cli_width import fits, headings, rcb, words

from conftest import ROOT
from migrated import migrated

PLAN = "milling-demo-part-for-the-customer-acme-precision-gmbh-lot-07"
TOOL = "SANDVIK-CoroMill-390-R390-11T308M-PM-1030-D10mm"


@pytest.fixture(scope="module")
def named(tmp_path_factory) -> str:
    """A database with the end-mill plan under :data:`PLAN`, its tool named :data:`TOOL`."""
    where = tmp_path_factory.mktemp("names-width")
    url = f"sqlite:///{where / 'rcb.db'}"
    migrated(url)
    text = (ROOT / "examples" / "milling_demo_part.toml").read_text(encoding="utf-8")
    assert text.count('name = "milling-demo-part"') == 1
    plan = where / "plan.toml"
    plan.write_text(
        text.replace("EM10-2F", TOOL).replace('name = "milling-demo-part"', f'name = "{PLAN}"'),
        encoding="utf-8",
    )
    done = rcb("plans", "create", str(plan), "--db", url)
    assert done.returncode == 0, done.stderr
    return url


def test_plans_keep_their_headings_and_dates_whole_beside_a_long_name(named):
    """Passed before too (rich's own collapse); kept: the name is now free text (review.py)."""
    done = rcb("plans", "--db", named)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    assert headings(done.stdout) == ["plans", "id", "name", "machine", "RCB", "ver"] + [
        "parts",
        "status",
        "created",
    ]
    assert {"ACE-V30", "running"} <= words(done.stdout)
    assert len([w for w in words(done.stdout) if w.startswith("20") and len(w) == 10]) == 1


def test_fleet_show_keeps_its_headings_whole_beside_a_long_name(named):
    done = rcb("fleet", "show", TOOL, "--db", named)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    expected = {"id", "plan", "machine", "readings", "in", "the", "fleet"}  # on two lines
    assert expected <= set(headings(done.stdout)), done.stdout
    assert {"no:", "part", "reported", "yet"} <= words(done.stdout)


def test_a_long_plan_name_in_a_table_title_is_not_folded(tmp_path) -> None:
    """``rcb plans show``: the end-mill plan's setpoints table (56 columns) folded its title's
    name mid-word (``...-gmbh-l`` / ``ot-07: setpoint version 1``); the table is now at
    least as wide as the title's longest word."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    text = (ROOT / "examples" / "milling_demo_part.toml").read_text(encoding="utf-8")
    plan = tmp_path / "plan.toml"
    plan.write_text(text.replace('name = "milling-demo-part"', f'name = "{PLAN}"'), "utf-8")
    assert rcb("plans", "create", str(plan), "--db", url).returncode == 0
    done = rcb("plans", "show", "1", "--db", url)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    titles = [line.strip() for line in done.stdout.splitlines() if PLAN in line]
    assert titles == [f"{PLAN}:", f"plan 1 {PLAN}:"], done.stdout  # setpoints', limits'


def test_each_limit_and_bound_stays_on_one_line_beside_a_long_tool(named) -> None:
    """``rcb plans show``: beside a 47-character tool the pairs split (``roughness_um`` over
    ``3.2``, ``feed_per_tooth_mm`` over ``0.018-0.047``) while the tool kept 34 columns."""
    done = rcb("plans", "show", "1", "--db", named)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    for pair in ("roughness_um 3.2", "feed_per_tooth_mm 0.018-0.047", "axial_depth_mm 1-4"):
        assert pair in done.stdout, done.stdout
