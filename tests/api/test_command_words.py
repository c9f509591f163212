"""Every ``rcb ...`` command a message, the web view or a report names is one ``rcb`` has.

The web view's empty plan list said ``rcb plan create`` (the command is ``rcb plans create``).
Scans the string literals (not docstrings) of every module under ``api/``: ``rcb WORD`` must
be a command or group of the typer app, and ``rcb GROUP WORD`` one of the group's commands,
unless the group runs alone (``rcb plans`` lists the plans: ``rcb plans lists them``).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import typer.main

from api.cli.main import app

API = Path(__file__).resolve().parents[2] / "api"
#: ``rcb`` and the one or two words after it (not ``rcb-supervisor``, ``/rcb``, ``rcb:``).
COMMAND = re.compile(r"(?<![\w/.-])rcb ([a-z][a-z-]*)(?: ([a-z][a-z-]*))?")


def _literals(path: Path) -> Iterator[tuple[int, str]]:
    """The string constants of a module, f-strings' parts included, docstrings left out."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if id(node) not in docstrings:
                yield node.lineno, node.value


def _unknown(root: typer.core.TyperGroup, first: str, second: str | None) -> bool:
    command = root.get_command(typer.Context(root), first)
    if command is None:
        return True
    if not isinstance(command, typer.core.TyperGroup) or second is None:
        return False
    subcommands = command.list_commands(typer.Context(command))
    return second not in subcommands and not command.invoke_without_command


def test_every_named_command_exists() -> None:
    root = typer.main.get_command(app)
    assert isinstance(root, typer.core.TyperGroup)
    named, unknown = set(), []
    for path in sorted(API.rglob("*.py")):
        for line, text in _literals(path):
            for found in COMMAND.finditer(text):
                named.add(found[0])
                if _unknown(root, found[1], found[2]):
                    unknown.append(f"{path.relative_to(API.parent)}:{line}: {found[0]}")
    assert unknown == []
    assert {"rcb plans create", "rcb keys create"} <= named  # the scan sees the web view's
