"""A command line click cannot parse is said naming the command and its usage
(:mod:`api.cli.usage_errors`).

Before, ``rcb parts list 1`` said ``Got unexpected extra argument(s) (1)``, ``rcb history`` said
``Missing argument 'PLAN'.`` and ``rcb fleet bogus`` ``No such command 'bogus'.``: not which
command refused the line nor how it is called.
"""

from __future__ import annotations

import subprocess

import pytest
from cli_errors_support import _rcb

from api.cli.main import app
from api.cli.usage_errors import said

#: click's own sentences, which no usage error may print any more.
CLICKS = ("Got unexpected", "Missing argument", "Missing option", "No such", "requires an")


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (
            ["parts", "list", "1"],
            "rcb parts: more arguments than it takes: 1 (usage: rcb parts [OPTIONS] {PLAN})",
        ),
        (
            ["history", "1", "2", "x y"],
            "rcb history: more arguments than it takes: 2 x y"
            " (usage: rcb history [OPTIONS] {PLAN})",
        ),
        (["history"], "rcb history: PLAN is missing (usage: rcb history [OPTIONS] {PLAN})"),
        (
            ["keys", "revoke"],
            "rcb keys revoke: ID is missing (usage: rcb keys revoke [OPTIONS] {ID})",
        ),
        (
            ["fleet", "exclude", "--plan", "1"],
            "rcb fleet exclude: --reason is required (usage: rcb fleet exclude [OPTIONS])",
        ),
        (["parts", "1", "--lst", "3"], "rcb parts: no option --lst (did you mean --last?)"),
        (["parts", "1", "--bogus"], "rcb parts: no option --bogus (rcb parts --help)"),
        (["parts", "1", "--last"], "--last needs a value"),
        (
            ["fleet", "bogus"],
            "rcb fleet: no command 'bogus' (show, law, imported, exclude, include)",
        ),
        (["plans", "bogus"], "rcb plans: no command 'bogus' (list, create, show)"),
        (["bogus"], "rcb: no command 'bogus' (rcb --help)"),  # too many commands to list
    ],
)
def test_a_line_click_refuses_names_the_command_and_its_usage(runner, tmp_path, args, line):
    db = tmp_path / "none.db"
    result = runner.invoke(app, args, env={"RCB_DATABASE_URL": f"sqlite:///{db}"})
    assert result.exit_code == 2, result.output
    assert result.stderr == f"rcb: error: {line}\n"
    assert not any(words in result.stderr for words in CLICKS)
    assert not db.exists()  # refused before anything was opened


def test_the_console_script_says_it_in_one_line_to_a_pipe(tmp_path):
    """The installed ``rcb``, as a script calls it: exit 2, one line, nothing on stdout."""
    done = subprocess.run(
        [_rcb(), "history", "1", "2", "--db", f"sqlite:///{tmp_path / 'none.db'}"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr == (
        "rcb: error: rcb history: more arguments than it takes: 2"
        " (usage: rcb history [OPTIONS] {PLAN})\n"
    )


class _Other(Exception):
    """An error that is none of click's usage errors."""

    ctx = None
    message = "Got unexpected extra argument(s) (1)"  # click's words, but no command to name


def test_said_leaves_what_it_cannot_place_to_clicks_words():
    assert said(_Other()) is None
    assert said(ValueError("x")) is None
