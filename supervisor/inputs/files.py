"""Reading the TOML files the supervisor takes (plan files, domain files); errors name the file."""

from __future__ import annotations

import tomllib
from pathlib import Path

from models.errors import InputError


def read_toml(path: Path, label: str) -> object:
    """The parsed TOML file at ``path``; ``label`` ("plan file" ...) names it in errors.

    Raises
    ------
    InputError
        No such file, unreadable, or not UTF-8 TOML; the field is ``label``, the value the path.
    """
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(label, str(path), "no such file") from None
    except OSError as err:
        raise InputError(label, str(path), f"cannot be read ({err.strerror})") from None
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise InputError(label, str(path), f"is not valid TOML ({err})") from None
