"""Every ``rcb ... --help`` shows the units its source writes in brackets (issue 30).

Typer renders help texts as Rich markup, in which ``[mm]`` is a tag: ``rcb cam depthmap
--help`` printed "Pixel size ." for "Pixel size [mm].". Each command of the app (the lazily
loaded ``rcb milling`` ones included) is rendered at 80 columns, and every bracketed word of its
docstring and of its options' and arguments' help must appear in what is printed.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

import typer
from typer.testing import CliRunner

from api.cli.main import app

try:  # recent typer vendors click as typer._click (as api/cli/main.py)
    from typer._click.core import Context
except ImportError:  # pragma: no cover - typer that uses click itself
    from click import Context  # type: ignore[assignment]

#: A bracketed word of a help text, as a unit is written: ``[mm]``, ``[N/mm^2]``, ``[cut]``.
BRACKETED = re.compile(r"\[[^\[\]\s]+\]")


def _commands(command: Any, path: tuple[str, ...]) -> Iterator[tuple[tuple[str, ...], Any]]:
    yield path, command
    if hasattr(command, "list_commands"):  # a group
        context = Context(command)
        for name in command.list_commands(context):
            sub = command.get_command(context, name)
            assert sub is not None, name
            yield from _commands(sub, (*path, name))


def _written(command: Any) -> set[str]:
    """The bracketed words of the help texts of ``command`` and its parameters, as written."""
    texts = [command.help or "", *(getattr(p, "help", None) or "" for p in command.params)]
    # a lazily loaded command has been escaped already (api/cli/helptext.py): undo it
    return set(BRACKETED.findall(" ".join(texts).replace("\\[", "[")))


def test_every_help_keeps_its_bracketed_units() -> None:
    runner = CliRunner()
    seen: dict[str, set[str]] = {}
    for path, command in _commands(typer.main.get_command(app), ()):
        result = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "80"})
        assert result.exit_code == 0, (path, result.output)
        shown = " ".join(result.output.split())
        missing = {unit for unit in _written(command) if unit not in shown}
        assert not missing, f"rcb {' '.join(path)} --help lost {sorted(missing)}"
        seen[" ".join(path)] = _written(command)
    # the walk reached the commands the issue names, and their units were checked
    assert "[mm]" in seen["cam depthmap"]
    assert "[mm]" in seen["fit"]
    assert "[cut]" in seen["milling domain"]
    assert len(seen) > 20


def test_help_of_depthmap_reads_pixel_size_in_mm() -> None:
    result = CliRunner().invoke(app, ["cam", "depthmap", "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0
    assert "Pixel size [mm]." in result.output
    assert "Pixel size ." not in result.output
