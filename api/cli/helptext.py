"""Help texts shown as written: a unit in brackets is not Rich markup.

Typer renders every help text (a command's docstring, an option's ``help=``) as Rich markup, in
which ``[mm]`` is a style tag: ``rcb cam depthmap --help`` printed "Pixel size ." for "Pixel
size [mm]." (issue 30). No help text of ``rcb`` uses markup on purpose, so each is escaped once,
in one place, when the command tree is built (:func:`escape_tree`, called by the root group and
by the lazily loaded groups), and the panels of Typer's Rich help stay as they are.

A docstring's paragraphs are wrapped at 100 columns in the source; Typer's Rich help keeps
their single line breaks (typer 0.29, ``rich_utils._fix_linebreaks``), so at 80 columns each
source line wrapped again on its own and the help read ragged (``rcb plans create --help``:
``id, which`` alone on a line). Each paragraph is joined into one line here (:func:`reflowed`) and
Rich wraps it to the terminal; a list item (``- ``, ``1. ``) keeps its own line, and a
paragraph that starts with a backspace (Click's mark for "as written") is kept as written.

A docstring marks a literal with double backquotes, as reStructuredText does; the terminal
showed them as written (``rcb replan --help``: two backquotes either side of ``--rcb
NAME=VALUE``), so the help shows the literal alone (:func:`unquoted`). The generated CLI
reference (``docs/hooks/cli_reference.py``) reads the docstring itself, where Markdown makes
the same marks code.
"""

from __future__ import annotations

import re
from typing import Any

from rich.markup import escape

_ESCAPED = "_rcb_help_escaped"
#: A reStructuredText literal (double backquotes either side): its text is what the help shows.
_LITERAL = re.compile(r"``(.+?)``", re.DOTALL)
#: A line that starts a list item keeps its own line: ``- item``, ``* item``, ``1. item``.
_ITEM = re.compile(r"\s*(?:[-*•]|\d+[.)])\s")


def unquoted(text: str) -> str:
    """``text`` with each reStructuredText literal's backticks off."""
    return _LITERAL.sub(r"\1", text)


def reflowed(text: str) -> str:
    """``text`` with each paragraph on one line, but list items and as-written paragraphs."""
    return "\n\n".join(_joined(p) for p in text.split("\n\n"))


def _joined(paragraph: str) -> str:
    if paragraph.startswith("\b"):
        return paragraph
    lines: list[str] = []
    for line in paragraph.split("\n"):
        if lines and not _ITEM.match(line):
            lines[-1] = f"{lines[-1].rstrip()} {line.strip()}"
        else:
            lines.append(line.rstrip())
    return "\n".join(lines)


def escape_tree(command: Any) -> None:
    """Reflow and escape the help of ``command``, its parameters and loaded subcommands, once."""
    if getattr(command, _ESCAPED, False):
        return
    setattr(command, _ESCAPED, True)
    for name in ("help", "short_help", "epilog"):
        text = getattr(command, name, None)
        if isinstance(text, str):
            setattr(command, name, escape(unquoted(reflowed(text))))
    for param in getattr(command, "params", ()):
        text = getattr(param, "help", None)
        if isinstance(text, str) and not getattr(param, _ESCAPED, False):
            param.help = escape(unquoted(reflowed(text)))
            setattr(param, _ESCAPED, True)
        _untyped_flag(param)
    helped = getattr(command, "get_help_option", None)
    if callable(helped):
        command.get_help_option = lambda ctx: _untyped_flag(helped(ctx))
    for sub in getattr(command, "commands", {}).values():
        escape_tree(sub)


def _untyped_flag(param: Any) -> Any:
    """A flag (``--json``, ``--help``) with no type column; ``param`` itself, to use in place.

    typer 0.29 showed ``<bool>`` beside each, as if the flag took a value (a first-day review).
    """
    if getattr(param, "is_flag", False) and not getattr(param, "count", False):
        param.metavar = ""
    return param
