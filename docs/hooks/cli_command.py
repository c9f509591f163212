"""The ``rcb`` CLI as a click command, for mkdocs-click (docs/reference/cli.md).

mkdocs-click documents a click command found by module and attribute; ``rcb`` is a Typer app,
so this hook exposes ``typer.main.get_command(app)`` as ``rcb`` and registers itself as the
module ``cli_command``, the name the directive ``:module: cli_command`` imports. Nothing here is
hand-written help: every line of the page comes from the app at build time.
"""

from __future__ import annotations

import sys
import typer

from api.cli.main import app

rcb = typer.main.get_command(app)

sys.modules["cli_command"] = sys.modules[__name__]
