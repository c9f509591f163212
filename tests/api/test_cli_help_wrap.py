"""Every ``rcb ... --help`` reads as wrapped prose at 80 columns, not as the source's lines.

A docstring is wrapped at 100 columns in the source; Typer's Rich help kept those line breaks,
so at 80 columns ``rcb plans create --help`` printed "id, which" alone on a line, every
source line wrapped again on its own (api/cli/helptext.py). Wrapped prose is greedy: a line
ends only where the next word would not fit, which this checks on the description of every
command, the lazily loaded ones included.
"""

from __future__ import annotations

import re

import typer
from test_cli_help_units import _commands
from typer.testing import CliRunner

from api.cli.helptext import reflowed
from api.cli.main import app

#: The width Rich wraps a help's description to at ``COLUMNS=80``: one space either side.
WIDTH = 78
#: A line that starts a list item may follow a short line.
ITEM = re.compile(r"(?:[-*•]|\d+[.)])\s")


def _description(output: str) -> list[str]:
    """The lines between ``Usage:`` and the first panel, without Rich's one-space margin."""
    lines = output.splitlines()
    start = next(i for i, line in enumerate(lines) if "Usage:" in line) + 1
    end = next((i for i, line in enumerate(lines) if line.startswith("╭")), len(lines))
    return [line[1:].rstrip() for line in lines[start:end]]


def _ragged(lines: list[str]) -> list[str]:
    """Lines that end before the next line's first word would have had to wrap."""
    return [
        here
        for here, after in zip(lines, lines[1:], strict=False)
        if here
        and after
        and not ITEM.match(after)
        and len(here) + 1 + len(after.split()[0]) <= WIDTH
    ]


def test_every_help_description_is_wrapped_prose() -> None:
    runner = CliRunner()
    checked = 0
    for path, _ in _commands(typer.main.get_command(app), ()):
        result = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "80"})
        assert result.exit_code == 0, (path, result.output)
        lines = _description(result.output)
        assert not _ragged(lines), f"rcb {' '.join(path)} --help: {_ragged(lines)}"
        checked += sum(1 for line in lines if line)
    assert checked > 100  # the walk read descriptions, not empty pages


def test_the_plans_create_help_joins_its_source_lines() -> None:
    result = CliRunner().invoke(app, ["plans", "create", "--help"], env={"COLUMNS": "80"})
    shown = " ".join(result.output.split())
    assert "Prints the new plan's id, which every PLAN argument takes" in shown
    assert not _ragged(_description(result.output))


def test_reflowed_keeps_paragraphs_list_items_and_as_written_blocks() -> None:
    text = "First\nparagraph.\n\n- one\n  more\n- two\n1. three\n\n\bkept\nas written"
    assert reflowed(text) == "First paragraph.\n\n- one more\n- two\n1. three\n\n\bkept\nas written"


def test_no_flag_shows_a_type_as_if_it_took_a_value() -> None:
    """A first-day review: typer 0.29 showed ``--json <bool>`` and ``--help <bool>``; an option
    that takes a value keeps its type (``--limit <int>``)."""
    runner = CliRunner()
    flags = 0
    for path, _ in _commands(typer.main.get_command(app), ()):
        output = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "80"}).output
        assert "<bool>" not in output, f"rcb {' '.join(path)} --help"
        flags += output.count("--help ")
    assert flags >= 50  # every command page read (50 on 2026-12-03)
    limit = runner.invoke(app, ["plans", "--help"], env={"COLUMNS": "80"}).output
    assert re.search(r"--limit\s+<int>", limit)
