"""The built-in tool catalogue, read from this package's data files."""

from __future__ import annotations

from functools import cache

from models import fields
from models.data import read_toml
from models.errors import InputError
from models.tool import Tool, tool_from_mapping

_FILES = ("ivester_aisi1045.toml",)


@cache
def catalogue() -> dict[str, Tool]:
    """Every packaged tool by name (Ivester & Heigel Tables 2-3 and Eq. 8)."""
    tools: dict[str, Tool] = {}
    for filename in _FILES:
        data = read_toml(filename)
        for i, entry in enumerate(data.get("tools", [])):
            where = f"{filename}:tools[{i}]"
            tool = tool_from_mapping(fields.mapping(entry, where), where)
            tools[tool.name] = tool
    return tools


def get_tool(name: str, field: str = "tool") -> Tool:
    """The catalogue tool called ``name``; the error names ``field`` and the known tools."""
    tools = catalogue()
    if name not in tools:
        raise InputError(field, name, f"unknown tool; catalogue has: {', '.join(sorted(tools))}")
    return tools[name]
