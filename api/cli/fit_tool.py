"""``rcb fit --write-tool``: the fitted model as one ``[[tools]]`` entry of a plan file (TOML).

:func:`tool_toml` writes the TOML by hand (the standard library only reads TOML) and checks it
by reading it back with :func:`models.tool.tool_from_mapping`; :func:`write_tool_file` writes the
file atomically (:func:`api.cli.common.write_atomically`).
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from api.cli.common import check_target, write_atomically
from models.errors import InputError
from models.fit import FitResult
from models.tool import tool_from_mapping


def tool_table(
    result: FitResult, name: str, process: str, quantity: str, source: str, reference: str
) -> dict[str, Any]:
    """The fitted model as a plan-file tool ``{name, process, description, source, models}``."""
    model = result.to_model(quantity, source, reference)
    return {
        "name": name,
        "process": process,
        "description": f"{quantity} model fitted by rcb fit",
        "source": source,
        "models": {
            quantity: {
                "K": model.K,
                "dK": model.dK,
                "exponents": dict(model.exponents),
                "exponent_stderr": dict(model.exponent_stderr),
                "source": model.source,
                "reference": model.reference,
            }
        },
    }


def tool_toml(tool: Mapping[str, Any]) -> str:
    """TOML text of one ``[[tools]]`` entry; checked by reading it back as a plan-file tool."""
    lines = ["# Written by rcb fit.", "", "[[tools]]"]
    models: Mapping[str, Mapping[str, Any]] = tool["models"]
    lines += [f"{key} = {_toml(value)}" for key, value in tool.items() if key != "models"]
    for quantity, model in models.items():
        lines += ["", f"[tools.models.{quantity}]"]
        lines += [f"{key} = {_toml(value)}" for key, value in model.items()]
    text = "\n".join(lines) + "\n"
    tool_from_mapping(tomllib.loads(text)["tools"][0], "--write-tool")
    return text


def _toml(value: Any) -> str:
    """A TOML value: string, finite float or inline table of numbers with bare keys."""
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, float):
        return repr(value)  # shortest repr, exact round trip; finite (checked by the model)
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {value!r} as TOML")


def _toml_string(text: str) -> str:
    """A TOML basic string: quote, backslash and control characters escaped."""
    out = []
    for char in text:
        if char in '"\\':
            out.append("\\" + char)
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04X}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def write_tool_file(path: Path, text: str) -> None:
    """Write the tool file whole or not at all (:func:`api.cli.common.write_atomically`)."""
    check_target(path, "--write-tool")
    try:
        data = text.encode("utf-8")
    except UnicodeEncodeError as err:
        raise InputError("--write-tool", str(path), f"cannot encode as UTF-8 ({err})") from None
    write_atomically(path, data, "--write-tool")
