"""CLI output for a reader at 80 columns and for a program.

Every table of every command, run as the real ``rcb`` in a subprocess with ``COLUMNS=80`` and
stdout a pipe (as in a log or a default terminal): no line is wider than the console, nothing
is cut with an ellipsis, and the numbers ``--json`` gives appear whole in the tables. At 40
columns nothing is cut either (long words fold onto the next line). ``rcb optimize --json`` on
an infeasible plan prints the REST service's 422 problem document.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from rich.cells import cell_len
from test_service import BODY, _reports

from api.cli.tables import fmt
from api.rest import problems
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine
from supervisor.errors import Conflict

from conftest import ROOT
from migrated import migrated

EXAMPLES = ROOT / "examples"
CSV = ROOT / "tests" / "data"
#: An ellipsis of rich (``…``) or of text (``...``): a cell cut short.
CUT = re.compile(r"…|\.\.\.")


def _rcb() -> str:
    script = Path(sys.executable).parent / "rcb"
    if not script.is_file():
        pytest.skip("the rcb console script is not installed")
    return str(script)


def rcb(
    *args: str, columns: int = 80, cwd: Path = ROOT, database: str | None = None
) -> subprocess.CompletedProcess[str]:
    """``rcb args``; ``database``: as ``$RCB_DATABASE_URL`` (no ``--db``)."""
    env = {**os.environ, "COLUMNS": str(columns)}
    if database is not None:
        env["RCB_DATABASE_URL"] = database
    return subprocess.run(
        [_rcb(), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )


def fits(stdout: str, columns: int = 80) -> None:
    """Every line within ``columns`` cells, nothing cut short."""
    assert stdout.strip(), "no output"
    for line in stdout.splitlines():
        assert cell_len(line) <= columns, line
        assert not CUT.search(line), line


def headings(stdout: str) -> list[str]:
    """The words above the heading rule (the title's and the headings')."""
    lines = stdout.splitlines()
    rule = next(i for i, line in enumerate(lines) if line.startswith("─"))
    return " ".join(lines[:rule]).split()


def words(stdout: str) -> set[str]:
    """The whitespace-separated words of ``stdout``, a leading ``±`` or trailing comma off."""
    return {w.lstrip("±").rstrip(",") for w in stdout.split()}


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> str:
    """A SQLite database with the demonstration plan and four parts reported."""
    url = f"sqlite:///{tmp_path_factory.mktemp('width') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    for body in _reports(4)[0]:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    engine.dispose()
    return url


TABLE_COMMANDS = {
    "optimize": ["optimize", str(EXAMPLES / "ivester_demo_part.toml")],
    "optimize-milling": ["optimize", str(EXAMPLES / "milling_demo_part.toml")],
    "optimize-constant-load": ["optimize", str(EXAMPLES / "tai_constant_load_part.toml")],
    "optimize-passes": ["optimize", str(EXAMPLES / "turning_passes_part.toml")],
    "optimize-milling-passes": ["optimize", str(EXAMPLES / "milling_passes_part.toml")],
    "predict": ["predict", "--tool", "CNMG432RN", "--depth-mm", "3", "--feed-mm-rev", "0.32"]
    + ["--speed-m-min", "200", "--diameter-mm", "60"],
    "domain": ["milling", "domain", str(EXAMPLES / "borangiu_domain.toml")],
    "setup": ["milling", "setup", str(CSV / "tai_end_milling_tests.csv")],
    "certify": ["certify", str(EXAMPLES / "ivester_demo_part.toml")]
    + ["--scenarios", "2", "--parts", "2", "--jobs", "1"],
    "fit": ["fit", str(CSV / "aisi12l14_turning_roughness.csv"), "--response", "Ra"]
    + ["--var", "depth_mm=d", "--var", "feed_mm_rev=f", "--var", "speed_m_min=Vc"],
    "examples": ["examples"],
}
DB_COMMANDS = {
    "plans": ["plans"],
    "history": ["history", "1"],
    "history-by-name": ["history", "ivester-demo-part"],
    "plans-show": ["plans", "show", "ivester-demo-part"],
    "history-operation": ["history", "1", "--operation", "finish-grooves"],
    "parts": ["parts", "1"],
    "replan": ["replan", "1", "--limit", "rough-od.force_N=1900", "--dry-run"],
    "keys": ["keys", "list"],
    "audit": ["audit"],
    "tools": ["tools", "list"],
    "tools-show": ["tools", "show", "CNMG432RN"],
    "fleet-law": ["fleet", "law", "CNMG432RN"],
}


@pytest.mark.parametrize("columns", [80, 40])
@pytest.mark.parametrize("command", sorted(TABLE_COMMANDS))
def test_tables_fit_the_console(command, columns):
    done = rcb(*TABLE_COMMANDS[command], columns=columns)
    assert done.returncode == 0, done.stderr
    fits(done.stdout, columns)


@pytest.mark.parametrize("columns", [80, 40])
@pytest.mark.parametrize("command", sorted(DB_COMMANDS))
def test_review_tables_fit_the_console(db, command, columns):
    done = rcb(*DB_COMMANDS[command], "--db", db, columns=columns)
    assert done.returncode == 0, done.stderr
    if command == "keys":  # no key yet: the headings alone
        assert "role" in done.stdout
        return
    fits(done.stdout, columns)


def test_plans_show_says_the_plans_settings_within_80_columns(db):
    """Its closing message was one line of 190 characters (the settings after the state)."""
    done = rcb("plans", "show", "ivester-demo-part", "--db", db)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert "rcb: plan 1 ivester-demo-part on lathe-22kW: running" in lines
    assert any(line.startswith("rcb: setpoint version 5, 4 parts; RCB learn") for line in lines)
    assert "z=4," in done.stderr  # as --rcb takes it: not Python's 4.0, nor floors={}
    assert "floors=" not in done.stderr and "4.0" not in done.stderr
    assert all(cell_len(line) <= 80 for line in lines), lines


@pytest.mark.parametrize("milling", [False, True])
def test_demo_tables_show_every_number_whole(milling, tmp_path):
    db = ["--db", f"sqlite:///{tmp_path / 'demo.db'}"]
    args = ["demo", "--parts", "3", *(["--milling"] if milling else []), *db]
    shown = rcb(*args)
    assert shown.returncode == 0, shown.stderr
    fits(shown.stdout)
    result = json.loads(rcb(*args, "--json").stdout)
    expected = set()
    for op in result["operations"]:
        for row in (op["catalog"], op["robust"], op["final"]):
            expected |= {fmt(v) for v in row["setpoint"].values()}
            expected.add(fmt(row["mrr_cm3_min"]))
            for q in ("force_N", "roughness_um"):
                expected.add(fmt(row["predicted"][q]["value"]))
                expected.add(fmt(row["measured"][q]["value"]))
                expected.add(f"{row['measured'][q]['uncertainty']:.3g}")
    # before: Ra measured printed as 0.61…, and the MRR heading as cm³/m…
    assert expected <= words(shown.stdout), expected - words(shown.stdout)
    assert "cm³/min" in shown.stdout
    # the summary's counts each on one line with their nouns (before: the cycle table's
    # caption, 39 cells wide, ended a line with "0 " and began the next "true-limit …")
    gain = result["gain_captured"]
    share = "" if gain is None else f"{100 * gain:.0f} % of the oracle's gain, "
    lines = shown.stdout.splitlines()
    assert f"3 parts, {share}setpoint version {result['setpoint_version']}" in lines
    violations, flagged = result["violations"], result["flagged"]
    assert f"{violations} true-limit violations, {flagged} flagged measurements" in lines


def test_plans_and_history_keep_names_dates_and_numbers_whole(db):
    plans = rcb("plans", "--db", db).stdout
    listed = json.loads(rcb("plans", "--db", db, "--json").stdout)["plans"][0]
    assert {listed["name"], listed["machine"], listed["created_at"][:10]} <= words(plans)
    history = rcb("history", "1", "--db", db).stdout
    data = json.loads(rcb("history", "1", "--db", db, "--json").stdout)
    numbers = {fmt(o["mrr_cm3_min"]) for v in data["versions"] for o in v["operations"]}
    numbers |= {fmt(v["cycle_time_min"]) for v in data["versions"]}
    assert numbers <= words(history), numbers - words(history)
    # each moved band by its operation, whole (before: rough-od.for…)
    moved = {
        f"{d['operation']}:"
        for v in data["versions"]
        for d in v["decisions"]
        if d["action"] != "hold"
    }
    assert moved and moved <= words(history)


def test_fit_says_its_source_in_one_line():
    """Under the table, not its caption: that wrapped at the table's 52 cells mid-phrase."""
    shown = rcb(*TABLE_COMMANDS["fit"], "--where", "VB=New")
    assert shown.returncode == 0, shown.stderr
    fits(shown.stdout)
    source = "fit of aisi12l14_turning_roughness.csv (1224 points, VB=New)"  # test_fit_command
    assert source in [line.rstrip() for line in shown.stdout.splitlines()]


def test_optimize_says_the_constant_load_in_whole_lines():
    """Under the end-mill's table, not its caption: that wrapped at the table's 58 cells and
    split "(upper set / by the setpoint)" (the figures: test_constant_load_setpoint.py)."""
    shown = rcb("optimize", str(EXAMPLES / "tai_constant_load_part.toml"))
    assert shown.returncode == 0, shown.stderr
    fits(shown.stdout)
    lines = [line.rstrip() for line in shown.stdout.splitlines()]
    assert "constant load: 0.238 A, feed 621.6-868 mm/min" in lines
    assert "(upper set by the setpoint); change tool at the lower limit" in lines


def test_optimize_json_on_an_infeasible_plan_is_a_problem_document(tmp_path):
    text = (EXAMPLES / "ivester_demo_part.toml").read_text(encoding="utf-8")
    assert text.count("{ force_N = 2000,") == 1
    plan = tmp_path / "infeasible.toml"
    plan.write_text(text.replace("{ force_N = 2000,", "{ force_N = 50,"), encoding="utf-8")
    done = rcb("optimize", str(plan), "--json")
    assert done.returncode == 3
    body = json.loads(done.stdout)
    # the REST service's infeasible answer (api/rest/problems.py): type, title, status, code
    assert body["type"] == problems._TYPE_BASE + "infeasible"
    assert (body["title"], body["status"], body["code"]) == (
        problems._TITLES[422],
        422,
        "infeasible",
    )
    assert body["field"] == "operations.rough-od.limits" and body["value"] == "rough-od"
    [entry] = body["conflicts"]
    assert entry["operation"] == "rough-od"
    [conflict] = entry["conflicts"]
    assert (conflict["name"], conflict["limit"], conflict["sense"]) == ("force_N", 50.0, "max")
    assert conflict["required"] > 50
    # the detail and the one line on stderr say the same, with the required limit
    assert done.stderr.strip() == f"rcb: infeasible: {body['detail']}"
    needs = Conflict("force_N", 50.0, conflict["required"], "max").texts()[1]
    assert f"needs a limit of at least {needs}" in body["detail"]


#: A ``name=value`` word of a table (``feed=0.3557``); its value up to the next blank.
PAIR = re.compile(r"(?<!\S)([a-z]+)=(\S*)")


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> dict[str, subprocess.CompletedProcess[str]]:
    """``rcb demo --parts 3`` of the lathe and of the end mill, each in a database of its own."""
    where = tmp_path_factory.mktemp("demos")
    runs = {}
    for kind in ("turning", "milling"):
        milling = ["--milling"] if kind == "milling" else []
        runs[kind] = rcb("demo", "--parts", "3", *milling, "--db", f"sqlite:///{where / kind}.db")
        assert runs[kind].returncode == 0, runs[kind].stderr
    return runs


def _url(run: subprocess.CompletedProcess[str]) -> str:
    return run.args[run.args.index("--db") + 1]


@pytest.mark.parametrize(
    ("kind", "operation"),
    [("turning", "rough-od"), ("turning", "finish-grooves"), ("milling", "slot")],
)
def test_one_operations_history_keeps_every_number_whole(demos, kind, operation):
    """Before: ``feed=0.355`` then ``7`` on the next line (0.3557), ``axial=2.84`` then ``6``."""
    args = ["history", "1", "--operation", operation, "--db", _url(demos[kind])]
    shown = rcb(*args)
    assert shown.returncode == 0, shown.stderr
    fits(shown.stdout)
    data = json.loads(rcb(*args, "--json").stdout)
    expected = [
        (name.split("_")[0], value)
        for version in data["versions"]
        for name, value in version["operations"][0]["setpoint"].items()
    ]
    pairs = PAIR.findall(shown.stdout)
    assert [name for name, _ in pairs] == [name for name, _ in expected]
    for (name, text), (_, value) in zip(pairs, expected, strict=True):
        assert float(text) == pytest.approx(value, rel=5e-4), (name, text, value)
    told = words(shown.stdout)
    assert {f"{v['serial']}" for v in data["versions"] if v["serial"]} <= told
    whole = {"version", "cause", "setpoint", "band", "Ra", "µm", "cm³/min", "binding"}
    whole |= {"decisions", "roughness_um", "force_N"}  # headings, a binding, a decision
    assert whole <= told, whole - told


def test_plans_show_keeps_the_milling_headings_and_numbers_whole(demos):
    """Before: the headings ``radial_depth_mm`` ... folded as ``radial_dept`` / ``h_mm``."""
    args = ["plans", "show", "1", "--db", _url(demos["milling"])]
    shown = rcb(*args)
    assert shown.returncode == 0, shown.stderr
    fits(shown.stdout)
    data = json.loads(rcb(*args, "--json").stdout)
    numbers = {fmt(x) for op in data["setpoints"]["operations"] for x in op["setpoint"].values()}
    assert numbers <= words(shown.stdout), numbers - words(shown.stdout)
    assert {"ap", "ae", "fz", "v", "m/min", "cm³/min"} <= words(shown.stdout)


@pytest.mark.parametrize("kind", ["turning", "milling"])
def test_demo_ends_on_its_commands_each_whole_on_a_line(demos, kind):
    """Before: ``... rcb history`` / ``  1 --db sqlite:///rcb-demo.db ...`` (not copyable)."""
    url = _url(demos[kind])
    lines = demos[kind].stderr.splitlines()
    name = re.search(r"as plan\s+1\s+\(([^)]+)\)", demos[kind].stderr)
    assert name is not None, demos[kind].stderr
    assert lines[-2:] == [
        f"  rcb history 1 --db {url}",
        # named after the plan: a second run's page does not overwrite the first's
        f"  rcb report 1 --db {url} --out {name.group(1)}.html",
    ]
    first = max(i for i, line in enumerate(lines) if line.startswith("rcb: stored in"))
    told = " ".join(line.strip() for line in lines[first:-2])  # the sentence, filled
    assert told.startswith(f"rcb: stored in {url} as plan 1 ") and told.endswith("to see it:")


def _within(stderr: str, columns: int = 80) -> list[str]:
    """The lines of ``stderr``, each checked within ``columns`` cells."""
    lines = stderr.splitlines()
    assert lines, "no message"
    for line in lines:
        assert cell_len(line) <= columns, line
    return lines


def test_report_says_what_it_wrote_within_80_columns(db, tmp_path):
    """Before: one line of 95 columns (``..., setpoint version 5, 163 kB``)."""
    done = rcb("report", "1", "--db", db, "--out", "demo.html", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    told = " ".join(line.strip() for line in _within(done.stderr))
    assert told.startswith("rcb: wrote demo.html: plan 1 ivester-demo-part, 4 parts (4 plotted)")
    assert re.search(r", setpoint version 5, \d+ kB$", told), told


def test_db_prune_says_what_it_deleted_within_80_columns(tmp_path):
    """Before: one line of 84 columns."""
    url = f"sqlite:///{tmp_path / 'prune.db'}"
    migrated(url)
    done = rcb("db", "prune", "--db", url)
    assert done.returncode == 0, done.stderr
    told = " ".join(line.strip() for line in _within(done.stderr))
    assert told.endswith(
        "rcb: deleted 0 audit entries older than 365d, 0 idempotency records older than 7d"
        " and 0 band states older than 30d that newer ones replaced"
    )


def test_audit_says_how_to_get_older_entries_with_the_command_whole(db):
    """Before: ``rcb: older entries: rcb audit --cursor ... --limit 3`` on one line of 104
    columns. Now the sentence, then the command alone on its line (longer than 80 columns: a
    cursor is not broken), which run as printed gives the next page: of the database read
    (``--db``; before, it was left out and the command read ``./rcb.db``)."""
    done = rcb("audit", "--limit", "3", "--db", db)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    hint, command = done.stderr.splitlines()
    assert hint == "rcb: older entries:"
    assert re.fullmatch(rf"  rcb audit --cursor \S+ --limit 3 --db {re.escape(db)}", command)
    older = rcb(*command.split()[1:])
    assert older.returncode == 0, older.stderr
    fits(older.stdout)


def test_a_next_page_hint_that_fits_stays_one_line(db):
    done = rcb("tools", "list", "--limit", "1", database=db)  # no --db to repeat
    assert done.returncode == 0, done.stderr
    [hint] = _within(done.stderr)
    assert re.fullmatch(r"rcb: next page: rcb tools list --cursor \S+ --limit 1", hint), hint


def test_the_audit_table_keeps_names_whole_and_folds_the_detail(tmp_path):
    """A process engineer's review at 80 columns: ``cli:roo`` / ``t`` and ``ivester`` /
    ``-demo-p`` / ``art``; a detail's path with digits (``operations[0].bounds...``) was kept
    whole as if a number, and the names were folded to make room for it."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    engine.dispose()
    bad = "rough-od.feed_mm_rev=nan:1"
    refused = rcb("replan", str(plan_id), "--bound", bad, "--by", "Jane Doe", "--db", url)
    assert refused.returncode == 2, refused.stderr
    done = rcb("audit", "--db", url)
    assert done.returncode == 0, done.stderr
    fits(done.stdout)
    shown = words(done.stdout)
    assert {"cli:Jane", "Doe", "ivester-demo-part", "refused"} <= shown, done.stdout
