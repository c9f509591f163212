"""A command line click could not parse, in rcb's words: the command, what is wrong, its usage.

click says ``Got unexpected extra argument(s) (1)`` to ``rcb parts list 1``, ``Missing argument
'PLAN'.`` to ``rcb history`` and ``No such command 'bogus'.`` to ``rcb fleet bogus``: true, but
not which command refused it nor how it is called, so an operator at the CLI is sent to
``--help`` to find out (a first-day walk-through, 2026-12-06). :func:`said` names the command
and says what it takes: ``rcb parts: more arguments than it takes: 1 (usage: rcb parts
[OPTIONS] {PLAN})``, in typer's usage words, as ``--help`` prints them (a required argument
in braces). A value typer's coercion refused is :mod:`api.cli.usage_words`'s.
"""

from __future__ import annotations

import re
from typing import Any

from api.cli.usage_words import param_name

#: click's sentence for arguments a command does not take (its Command.parse_args).
_EXTRA = re.compile(r"Got unexpected extra arguments?(?:\(s\))? \((?P<args>.*)\)\Z", re.S)
#: click's sentence for a subcommand a group does not have (typer's resolve_command).
_NO_COMMAND = re.compile(r"No such command (?P<name>.+?)\.?\Z", re.S)
#: A group's commands named in the error up to this many; more: where ``--help`` lists them.
_LISTED = 8
#: click's sentence for an option given no value (its parser's).
_NO_VALUE = re.compile(r"Option (?P<name>'[^']*') requires (?:an argument|\d+ arguments)\.?\Z")


def said(err: Any) -> str | None:
    """``err`` (a usage error of click's) in rcb's words; None if not one of those known."""
    kind = type(err).__name__
    message = str(getattr(err, "message", "") or "")
    if kind == "BadOptionUsage" and (found := _NO_VALUE.match(message)):
        # click's parser raises it with no context: the option alone is named
        return f"{found['name'].strip(chr(39))} needs a value"
    ctx = getattr(err, "ctx", None)
    if ctx is None:
        return None
    if kind == "MissingParameter":
        return _missing(err, ctx)
    if kind == "NoSuchOption":
        return _no_option(err, ctx)
    if found := _EXTRA.match(message):
        # click joined the arguments with spaces: how many there were is lost, so not counted
        return f"{ctx.command_path}: more arguments than it takes: {found['args']} {_usage(ctx)}"
    if found := _NO_COMMAND.match(message):
        names = ctx.command.list_commands(ctx)
        listed = ", ".join(names) if len(names) <= _LISTED else f"{ctx.command_path} --help"
        return f"{ctx.command_path}: no command {found['name']} ({listed})"
    return None


def _missing(err: Any, ctx: Any) -> str | None:
    """An argument or a required option not given: which, and the command's usage."""
    param = getattr(err, "param", None)
    if param is None:
        return None
    option = any(str(o).startswith("-") for o in getattr(param, "opts", ()))
    if getattr(err, "param_type", None) == "option" or option:
        return f"{ctx.command_path}: {param_name(param)} is required {_usage(ctx)}"
    return f"{ctx.command_path}: {param_name(param)} is missing {_usage(ctx)}"


def _no_option(err: Any, ctx: Any) -> str:
    """An option the command does not have: the nearest it has, else where they are listed."""
    name = getattr(err, "option_name", "") or ""
    near = sorted(getattr(err, "possibilities", None) or ())
    hint = f"(did you mean {' or '.join(near)}?)" if near else f"({ctx.command_path} --help)"
    return f"{ctx.command_path}: no option {name} {hint}"


def _usage(ctx: Any) -> str:
    """``(usage: rcb parts [OPTIONS] {PLAN})``: the command's usage line, as ``--help`` has it."""
    pieces = " ".join(ctx.command.collect_usage_pieces(ctx))
    return f"(usage: {ctx.command_path} {pieces})"
