"""rcb history --last, rcb parts --last / --since read only what they show; --json streams
(issue 17, item 1). SQLite: every statement's query plan seeks, none reads a table whole."""

from __future__ import annotations

import json

import pytest
from sqlalchemy import Engine, event
from test_service import BODY, _reports

from api.cli import parts_view
from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine
from supervisor.rcb.state import RcbSettings

from migrated import migrated

#: Tables that grow with the plan's life.
GROWING = ("parts", "measurements", "rcb_decisions", "setpoint_versions", "setpoints")


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    url = f"sqlite:///{tmp_path_factory.mktemp('paging') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    bayes = RcbSettings("bayes")  # a setpoint version per part
    plan_id = create_plan(engine=engine, body=BODY, settings=bayes).body["id"]
    bodies, _ = _reports(30, settings=bayes)
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    engine.dispose()
    return url, plan_id, bodies


class Heard:
    """Every SELECT any engine runs while listening, with its parameters."""

    def __init__(self) -> None:
        self.statements: list[tuple[str, object]] = []

    def __call__(self, conn, cursor, statement, parameters, context, executemany) -> None:
        if statement.lstrip().upper().startswith("SELECT"):
            self.statements.append((statement, parameters))


def _run(runner, url, *args):
    heard = Heard()
    event.listen(Engine, "before_cursor_execute", heard)
    try:
        result = runner.invoke(app, [*args, "--db", url])
    finally:
        event.remove(Engine, "before_cursor_execute", heard)
    return result, heard.statements


def _scans(url, statements):
    """The query-plan lines that read a growing table whole."""
    engine = make_engine(url)
    out = []
    with engine.connect() as connection:
        raw = connection.connection.driver_connection
        for statement, parameters in statements:
            for row in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters):
                if any(row[-1].startswith(f"SCAN {name}") for name in GROWING):
                    out.append(row[-1])
    engine.dispose()
    return out


def test_history_last_shows_the_newest_versions_and_reads_only_those(runner, stored):
    url, plan_id, bodies = stored
    result, statements = _run(runner, url, "history", str(plan_id), "--last", "3", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert [v["version"] for v in data["versions"]] == [29, 30, 31]
    assert [v["serial"] for v in data["versions"]] == ["SN-0028", "SN-0029", "SN-0030"]
    assert all(v["decisions"] for v in data["versions"])  # each version's decisions, no more
    assert data["next_cursor"] == "29"  # the version --before takes (REST's cursor: "n29")
    assert _scans(url, statements) == []
    assert len(statements) <= 12
    table, _ = _run(runner, url, "history", str(plan_id), "--last", "2")
    assert table.exit_code == 0 and "SN-0030" in table.stdout and "SN-0028" not in table.stdout


def test_history_before_pages_back_to_the_first_version(runner, stored):
    """--before V: the versions older than V; the table names the command for the page before."""
    url, plan_id, _ = stored
    result, statements = _run(runner, url, "history", str(plan_id), "--last", "3", "--before", "29")
    assert result.exit_code == 0, result.output
    data = json.loads(
        _run(runner, url, "history", str(plan_id), "--last", "3", "--before", "29", "--json")[
            0
        ].stdout
    )
    assert [v["version"] for v in data["versions"]] == [26, 27, 28]
    assert [v["serial"] for v in data["versions"]] == ["SN-0025", "SN-0026", "SN-0027"]
    assert data["next_cursor"] == "26"
    assert f"older versions: rcb history {plan_id} --before 26" in result.stdout
    assert _scans(url, statements) == []
    first = _run(runner, url, "history", str(plan_id), "--last", "5", "--before", "3", "--json")[0]
    assert [v["version"] for v in json.loads(first.stdout)["versions"]] == [1, 2]
    assert json.loads(first.stdout)["next_cursor"] is None
    table = _run(runner, url, "history", str(plan_id), "--before", "3")[0]
    assert table.exit_code == 0 and "older versions" not in table.stdout
    newest = _run(runner, url, "history", str(plan_id), "--last", "3")[0].stdout
    assert "--before 29" in newest


def test_parts_last_and_since_read_only_what_they_show(runner, stored):
    url, plan_id, bodies = stored
    result, statements = _run(runner, url, "parts", str(plan_id), "--last", "2", "--json")
    assert result.exit_code == 0, result.output
    last = json.loads(result.stdout)
    assert [p["serial"] for p in last["parts"]] == ["SN-0029", "SN-0030"]
    assert (
        last["parts"][1]["operations"][0]["measurements"]["force_N"]["value"]
        == (bodies[29]["operations"][0]["measurements"]["force_N"]["value"])
    )
    assert _scans(url, statements) == []
    whole = json.loads(_run(runner, url, "parts", str(plan_id), "--json")[0].stdout)["parts"]
    assert [p["serial"] for p in whole] == [b["serial"] for b in bodies]
    since = whole[25]["received_at"]
    result, statements = _run(runner, url, "parts", str(plan_id), "--since", since, "--json")
    assert [p["serial"] for p in json.loads(result.stdout)["parts"]] == [
        f"SN-{i:04d}" for i in range(26, 31)
    ]
    assert _scans(url, statements) == []
    both, _ = _run(runner, url, "parts", str(plan_id), "--since", since, "--last", "2", "--json")
    assert [p["serial"] for p in json.loads(both.stdout)["parts"]] == ["SN-0029", "SN-0030"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["history", "1", "--last", "0"], "--last = 0"),
        (["history", "1", "--before", "0"], "--before = 0: a setpoint version is 1 to 2147483647"),
        (["history", "1", "--before", "2147483648"], "--before = 2147483648"),
        (["history", "1", "--before", "1"], "--before = 1: no setpoint version is older"),
        (["parts", "1", "--last", "501"], "--last = 501"),
        (["parts", "99"], "PLAN = 99: no plan with id 99 (rcb plans lists them)"),
        (["parts", "99", "--json"], "PLAN = 99: no plan with id 99 (rcb plans lists them)"),
    ],
)
def test_paging_options_out_of_bounds_are_one_line(runner, stored, args, message):
    result, _ = _run(runner, stored[0], *args)
    assert result.exit_code == 2 and message in result.stderr, result.output
    assert "Traceback" not in result.output and result.stdout == ""


def test_parts_json_is_written_page_by_page(capsys):
    """The first page is on stdout before the second is read: nothing holds every part."""

    def pages():
        yield [{"serial": "A"}, {"serial": "B"}]
        assert json.dumps({"serial": "B"}) in capsys.readouterr().out
        yield [{"serial": "C"}]

    parts_view.stream_json(7, pages())
    assert capsys.readouterr().out.endswith('{"serial": "C"}\n]}\n')


@pytest.mark.parametrize(
    "args", [(), ("--last", "3"), ("--since", "1m"), ("--last", "3", "--json")]
)
def test_parts_of_a_plan_without_parts_say_so(runner, tmp_path, args):
    """``rcb parts`` of a plan no part was reported to: a line saying so (it printed nothing,
    and with ``--last`` a traceback: a new user's and an integrator's review, 2026-12-02)."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    create_plan(engine=engine, body=BODY)
    engine.dispose()
    result, _ = _run(runner, url, "parts", BODY["name"], *args)
    assert result.exit_code == 0 and "Traceback" not in result.output, result.output
    if "--json" in args:
        assert json.loads(result.stdout)["parts"] == []
    elif "--since" in args:
        assert result.stdout.strip() == "plan 1: parts since 1m: none"
    else:
        assert result.stdout.strip() == "plan 1: parts: none reported yet"


def test_the_older_versions_command_reads_the_same_database_and_operation(runner, stored):
    """A process engineer's review: ``older versions: rcb history 1 --before 4`` left out
    ``--db`` and ``--operation``; run as printed, it read ``./rcb.db``'s plan 1 instead."""
    url, plan_id, _ = stored
    shown = _run(runner, url, "history", str(plan_id), "--last", "2", "--operation", "rough-od")
    [hint] = [line for line in shown[0].stdout.splitlines() if "older versions" in line]
    command = f"rcb history {plan_id} --before 30 --operation rough-od --db {url}"
    assert hint == f"older versions: {command}"
    older = runner.invoke(app, [*command.split()[1:], "--last", "1", "--json"])
    data = json.loads(older.stdout)
    assert [v["version"] for v in data["versions"]] == [29]
    assert [op["name"] for op in data["versions"][0]["operations"]] == ["rough-od"]


def test_a_password_is_never_printed_in_a_command_to_run_next():
    from api.cli.common import again_db

    assert again_db(None) == ""
    assert again_db("postgresql+psycopg://rcb:s3cret@127.0.0.1/plant") == " --db URL"
    assert again_db("postgresql+psycopg://rcb@127.0.0.1/plant") == (
        " --db postgresql+psycopg://rcb@127.0.0.1/plant"
    )
    assert again_db("sqlite:///my plant.db") == " --db 'sqlite:///my plant.db'"
