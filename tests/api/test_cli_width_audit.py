"""``rcb audit`` at 80 columns with long names: numbers, keys and headings whole.

Before: a 24-character plan name in the target column and an authentication failure's detail
(``window_start_s: 1796395440.0, window_s: 60.0``) left the detail 6 columns: ``179639`` /
``5440.0`` / ``,``, ``window`` / ``_start`` / ``_s:``. A route's path as the action
(``POST /api/v1/plans/{plan_id}/parts``, its ``v1`` a digit: "a number, never folded") made
the table wider than the console, and rich cut its right edge off: ``ref`` of ``refused``, and
no detail at all. Then the detail, a sixth column, had 15 of 80 columns and a refusal took
11 lines: it is now on the lines under its entry's row, as wide as the console.
"""

from __future__ import annotations

import json
import re

import pytest
from sqlalchemy.orm import Session
from test_cli_width import fits, headings, rcb, words

from api.cli.audit import said
from db import audit_windows
from db.engine import make_engine

from conftest import DEMO_PLAN
from migrated import migrated

#: A plan's name of 24 characters, as the audit table keeps one whole (api/cli/audit.py).
NAME = "ivester-demo-part-lot-07"


@pytest.fixture(scope="module")
def audited(tmp_path_factory) -> str:
    """A database whose audit log has a plan, a key, a replan, a refusal, a wrong key."""
    where = tmp_path_factory.mktemp("audit-width")
    url = f"sqlite:///{where / 'rcb.db'}"
    migrated(url)
    text = DEMO_PLAN.read_text(encoding="utf-8")
    plan = where / "plan.toml"
    plan.write_text(text.replace('name = "ivester-demo-part"', f'name = "{NAME}"', 1))
    for args in (
        ["plans", "create", str(plan)],
        ["keys", "create", "--role", "mes", "--label", "line 3"],
        ["replan", "1", "--rcb", "z=3"],
    ):
        done = rcb(*args, "--db", url)
        assert done.returncode == 0, done.stderr
    refused = rcb("replan", "1", "--bound", "rough-od.feed_mm_rev=nan:1", "--db", url)
    assert refused.returncode == 2, refused.stderr
    engine = make_engine(url)
    with Session(engine) as session, session.begin():  # as the service counts a wrong key
        audit_windows.add(
            session=session,
            client="127.0.0.1",
            action="POST /api/v1/plans/{plan_id}/parts",
            reason="unknown or revoked key",
            start_s=1796395440.0,
            window_s=60.0,
            delta=1,
        )
    engine.dispose()
    return url


def test_the_audit_table_keeps_numbers_keys_and_headings_whole_at_80_columns(audited):
    done = rcb("audit", "--db", audited)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    assert headings(done.stdout) == ["audit", "at", "(UTC)", "actor", "action", "target"] + [
        "result"
    ]
    entries = json.loads(rcb("audit", "--db", audited, "--json").stdout)["entries"]
    shown = words(done.stdout)
    numbers = {
        json.dumps(value)
        for entry in entries
        if isinstance(entry["detail"], dict)
        for value in entry["detail"].values()
        if isinstance(value, int | float)
    }
    assert numbers >= {"1796395440.0", "60.0", "1"}
    assert numbers <= shown, numbers - shown
    assert {"127.0.0.1", "window_start_s:", "window_s:", "message:"} <= shown
    # each entry's time whole, and the results right of the names: none cut off at the edge
    told = {e["at"][11:19] for e in entries} | {"refused", "201", "mes"}
    assert told <= shown, told - shown
    # the long names fold first (the name, the route, "unauthenticated"), cut never
    assert "ivester-demo" in done.stdout and "unauthentica" in done.stdout


@pytest.mark.parametrize("columns", [60, 40])
def test_a_narrower_audit_table_folds_names_not_numbers(audited, columns):
    done = rcb("audit", "--db", audited, columns=columns)
    assert done.returncode == 0, done.stderr
    fits(done.stdout, columns)
    told = set(done.stdout.split())
    assert {"1796395440.0,", "60.0", "127.0.0.1,"} <= told, done.stdout
    dates = re.findall(r"^\d{4}-\d\d-\d\d ", done.stdout, re.M)
    assert len(dates) == len(json.loads(rcb("audit", "--db", audited, "--json").stdout)["entries"])


def test_each_entry_is_its_row_and_its_detail_under_it_at_80_columns(audited):
    done = rcb("audit", "--db", audited)
    assert done.returncode == 0, done.stderr
    entries = json.loads(rcb("audit", "--db", audited, "--json").stdout)["entries"]
    lines = done.stdout.splitlines()
    rows = [i for i, line in enumerate(lines) if re.match(r"\d{4}-\d\d-\d\d \d\d:", line)]
    assert len(rows) == len(entries), done.stdout  # each row's date and time on one line
    for entry, first, end in zip(entries, rows, [*rows[1:], len(lines)], strict=True):
        assert entry["at"][:19].replace("T", " ") in lines[first]
        folded = [line for line in lines[first + 1 : end] if line.startswith(" " * 21)]
        under = lines[first + 1 + len(folded) : end]  # a long name's fold, then the detail
        assert all(re.match(r" {4}\S", line) for line in under), under
        detail = entry["detail"] or {}
        told = {json.dumps(v) if not isinstance(v, str) else v for v in detail.values() if v}
        shown = " ".join(" ".join(line.split()) for line in under)
        assert all(value in shown for value in told), (told, shown)
        assert len(under) <= 3, under  # a refusal's message took 11 lines in a sixth column


def test_a_console_too_narrow_for_a_row_still_shows_every_entry_and_its_detail(audited):
    """At 12 columns a row's time folds a character a line, its space a blank line of its
    own: the rows were told apart by their time, then by the blank line between rows, and
    the command failed with a traceback (zip() of unequal lengths)."""
    done = rcb("audit", "--db", audited, columns=12)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    fits(done.stdout, 12)
    entries = json.loads(rcb("audit", "--db", audited, "--json").stdout)["entries"]
    # each detail starts under its row with its first key (folded at the 8 columns left)
    firsts = [f"    {next(iter(e['detail']))}:"[:12] for e in entries if e["detail"]]
    starts = [line.rstrip() for line in done.stdout.splitlines() if re.match(r" {4}\S", line)]
    assert all(first in starts for first in firsts), (firsts, starts)
    assert {"reason:", "error:"} <= set(done.stdout.split()), done.stdout


@pytest.mark.parametrize(
    ("stored", "shown"),
    [
        ("201", "201 created"),  # a write at the CLI, audited with the REST service's status
        ("replayed 201", "replayed 201 created"),
        ("409", "409 conflict"),
        ("599", "599"),  # no status Python knows: as stored
        ("accepted", "accepted"),
        ("out of the fleet until rcb fleet include", "out of the fleet until rcb fleet include"),
    ],
)
def test_a_status_is_shown_with_its_words(stored, shown):
    assert said(stored) == shown
