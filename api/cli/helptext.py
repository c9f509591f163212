"""Help texts shown as written: a unit in brackets is not Rich markup.

Typer renders every help text (a command's docstring, an option's ``help=``) as Rich markup, in
which ``[mm]`` is a style tag: ``rcb cam depthmap --help`` printed "Pixel size ." for "Pixel
size [mm]." (issue 30). No help text of ``rcb`` uses markup on purpose, so each is escaped once,
in one place, when the command tree is built (:func:`escape_tree`, called by the root group and
by the lazily loaded groups), and the panels of Typer's Rich help stay as they are.
"""

from __future__ import annotations

from typing import Any

from rich.markup import escape

_ESCAPED = "_rcb_help_escaped"


def escape_tree(command: Any) -> None:
    """Escape the help of ``command``, its parameters and its loaded subcommands, once each."""
    if getattr(command, _ESCAPED, False):
        return
    setattr(command, _ESCAPED, True)
    for name in ("help", "short_help", "epilog"):
        text = getattr(command, name, None)
        if isinstance(text, str):
            setattr(command, name, escape(text))
    for param in getattr(command, "params", ()):
        text = getattr(param, "help", None)
        if isinstance(text, str) and not getattr(param, _ESCAPED, False):
            param.help = escape(text)
            setattr(param, _ESCAPED, True)
    for sub in getattr(command, "commands", {}).values():
        escape_tree(sub)
