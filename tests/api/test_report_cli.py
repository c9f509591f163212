"""rcb report, the command: it writes the HTML record of a plan (api/cli/html_report.py) from the
database given or in the environment, in one line when refused or when the write fails, and
nothing else pays for matplotlib. The page itself: test_report.py.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from report_support import record_page, stored_record


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    return stored_record(tmp_path_factory)


@pytest.fixture(scope="module")
def page(stored):
    return record_page(stored)


INPUT_ERROR = 2


@pytest.fixture
def cli():
    from api.cli.main import app

    return app


def test_cli_writes_the_page(runner, cli, stored, page, tmp_path):
    url, plan_id, *_ = stored
    out = tmp_path / "report.html"
    out.write_text("old")
    result = runner.invoke(cli, ["report", str(plan_id), "--out", str(out), "--db", url])
    assert result.exit_code == 0, result.output
    assert out.read_text(encoding="utf-8") == page  # the same data, the same page
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]  # no temporary file left
    assert result.stdout == "" and f"rcb: wrote {out}" in " ".join(result.stderr.split())
    assert str(out) in result.stderr  # wrapped at 80 columns, the path kept whole
    size = out.stat().st_size
    assert 150_000 < size < 250_000  # about 190 kB for 6 operations and 10 parts (docs)


def test_cli_reads_the_database_from_the_environment(runner, cli, stored, tmp_path, monkeypatch):
    url, plan_id, *_ = stored
    monkeypatch.setenv("RCB_DATABASE_URL", url)
    out = tmp_path / "r.html"
    result = runner.invoke(cli, ["report", str(plan_id), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert out.is_file()


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (["999", "--out", "{tmp}/r.html", "--db", "{url}"], "PLAN = 999: no such plan"),
        (["1", "--out", "{tmp}/missing/r.html", "--db", "{url}"], "--out = '{tmp}/missing/r.html'"),
        (["1", "--out", "{tmp}", "--db", "{url}"], "--out = '{tmp}': is a directory"),
        (["1", "--out", "{tmp}/r.html", "--db", "sqlite:///{tmp}/none.db"], "--db = "),
        (["1", "--out", "{tmp}/r.html", "--db", "nonsense"], "--db = 'nonsense'"),
    ],
)
def test_cli_refuses_bad_input_in_one_line(runner, cli, stored, tmp_path, args, field):
    url, *_ = stored
    filled = [a.format(tmp=tmp_path, url=url) for a in args]
    result = runner.invoke(cli, ["report", *filled])
    assert result.exit_code == INPUT_ERROR, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rcb: error: ")
    assert field.format(tmp=tmp_path) in lines[0]
    assert "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []  # nothing written, no database file created


def test_cli_plots_the_last_parts(runner, cli, stored, page, tmp_path):
    url, plan_id, *_ = stored
    out = tmp_path / "r.html"
    args = ["report", str(plan_id), "--out", str(out), "--db", url]
    result = runner.invoke(cli, [*args, "--last", "2"])
    assert result.exit_code == 0, result.output
    assert "the last 2 parts" in out.read_text(encoding="utf-8")
    assert out.stat().st_size < len(page.encode("utf-8"))
    refused = runner.invoke(cli, [*args, "--last", "0"])
    assert refused.exit_code == INPUT_ERROR and "--last" in refused.output


def test_cli_reports_a_failed_write_in_one_line(runner, cli, stored, tmp_path, monkeypatch):
    url, plan_id, *_ = stored
    out = tmp_path / "r.html"

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr("api.cli.atomic.os.replace", refuse)
    result = runner.invoke(cli, ["report", str(plan_id), "--out", str(out), "--db", url])
    assert result.exit_code == INPUT_ERROR
    assert result.stderr == f"rcb: error: --out = '{out}': cannot be written (Permission denied)\n"
    assert list(tmp_path.iterdir()) == []  # the temporary file is removed


def test_cli_refuses_an_unwritable_directory(runner, cli, stored, tmp_path):
    url, plan_id, *_ = stored
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if _writable(locked):
            pytest.skip("running as a user who can write anywhere (root)")
        out = locked / "r.html"
        result = runner.invoke(cli, ["report", str(plan_id), "--out", str(out), "--db", url])
        assert result.exit_code == INPUT_ERROR
        assert result.stderr.startswith(f"rcb: error: --out = '{out}': cannot be written")
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o700)


def test_other_commands_do_not_pay_for_matplotlib():
    code = "import sys, api.cli.html_report; assert 'matplotlib' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def _writable(directory):
    try:
        (directory / "probe").write_text("")
    except OSError:
        return False
    (directory / "probe").unlink()
    return True
