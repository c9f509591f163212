"""Two costs every run of the suite paid many times over, paid once (a pytest plugin that
tests/conftest.py loads).

- **The project's bytecode, compiled before any process starts.** The suite starts some 500
  Python processes of this project (``rcb serve`` about 160 times, ``rcb`` commands, a
  server's worker processes, collectors), each importing 150-300 of its modules. Where
  bytecode is not written (``PYTHONDONTWRITEBYTECODE``, as on the hosts CI runs on) and on a
  fresh clone, each of them compiled every one of those modules from source again: about
  0.18 s of CPU per process (``import api.rest.app, api.cli.main, db.engine``: 1.24 s against
  1.06 s with the bytecode there, 2026-12-06). :func:`pytest_configure` compiles them once,
  into the ``__pycache__`` folders Python itself would write (git ignores them); a file
  already compiled is skipped, and a tree that cannot be written is left as it was.
- **Typer's click command, built once per app.** ``CliRunner.invoke(app, ...)`` builds the
  whole click command tree of ``app`` from its functions' signatures on every call (about
  30 ms for ``rcb``), and the suite invokes ``rcb`` in process some 2000 times. The command
  is built once per app object here and reused: click builds a new context on every call,
  ``rcb``'s lazy groups keep the commands they loaded, and its help escaping runs once per
  command (``api/cli/helptext.py``), as in a process that runs several commands.
"""

from __future__ import annotations

import compileall
import weakref
from pathlib import Path
from typing import Any

import pytest
import typer.main
import typer.testing

ROOT = Path(__file__).resolve().parent.parent
#: The folders whose modules the suite's processes import (alembic: the migration scripts
#: every ``rcb db upgrade`` and server start reads).
COMPILED = ("api", "db", "supervisor", "models", "alembic", "tests")

_COMMANDS: weakref.WeakKeyDictionary[typer.Typer, Any] = weakref.WeakKeyDictionary()


def _command_once(app: typer.Typer) -> Any:
    """``typer.main.get_command(app)``, built on the first call for ``app`` and kept."""
    command = _COMMANDS.get(app)
    if command is None:
        command = _COMMANDS[app] = typer.main.get_command(app)
    return command


# typer.testing builds the command through this module-level name; if a typer release renames
# it, the suite must say so rather than silently build every command again
if not callable(getattr(typer.testing, "_get_command", None)):
    raise RuntimeError("typer.testing._get_command is gone: tests/suite_speed.py needs updating")
typer.testing._get_command = _command_once


def pytest_configure(config: pytest.Config) -> None:
    """The project's modules compiled once, by the run's first process (the xdist controller,
    or the only process), before any worker or server starts."""
    if hasattr(config, "workerinput"):
        return
    for folder in COMPILED:
        compileall.compile_dir(ROOT / folder, quiet=2)
