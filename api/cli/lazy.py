"""A command group whose commands' modules are imported only when the group itself runs.

``rcb --help`` lists such a group by its own help, without importing its commands; ``rcb
milling ...`` (``--help`` included) imports them then, each registered as typer registers a
function, so every help text and option is the one an eager registration gives. Used where a
command's options need values of a module that loads NumPy (``rcb milling setup``'s Tai safety
factor, ``rcb milling control``'s controllers): README, "Speed".
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

import typer
from typer.core import TyperGroup

from api.cli.helptext import escape_tree


def _load(name: str, target: str) -> Any:
    """The click command of ``target`` (``"module:function"``), named ``name``."""
    module, _, attribute = target.partition(":")
    function = getattr(importlib.import_module(module), attribute)
    single = typer.Typer(add_completion=False)
    single.command(name)(function)
    command = typer.main.get_command(single)
    escape_tree(command)  # "[mm]" in a help text is a unit, not Rich markup
    return command


def lazy_group(commands: Mapping[str, str]) -> type[TyperGroup]:
    """A group class listing ``commands`` (name -> ``"module:function"``) in their order."""
    order = tuple(commands)

    class LazyGroup(TyperGroup):
        """Imports a command's module the first time the command is listed or looked up."""

        def list_commands(self, ctx: Any) -> list[str]:
            return [*super().list_commands(ctx), *(n for n in order if n not in self.commands)]

        def get_command(self, ctx: Any, cmd_name: str) -> Any:
            if cmd_name in commands and cmd_name not in self.commands:
                self.commands[cmd_name] = _load(cmd_name, commands[cmd_name])
            return super().get_command(ctx, cmd_name)

    return LazyGroup
