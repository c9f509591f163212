"""Reading the TOML files the supervisor takes (plan files, domain files); errors name the file."""

from __future__ import annotations

import tomllib
from pathlib import Path

from models.bounds import MAX_DOCUMENT_BYTES
from models.errors import InputError


def read_toml(path: Path, label: str) -> object:
    """The parsed TOML file at ``path``; ``label`` ("plan file" ...) names it in errors.

    Raises
    ------
    InputError
        No such file, unreadable, over :data:`models.bounds.MAX_DOCUMENT_BYTES` (a REST body's
        bound: checked before the file is parsed), or not UTF-8 TOML; the field is ``label``,
        the value the path.
    """
    try:
        with path.open("rb") as file:
            raw = file.read(MAX_DOCUMENT_BYTES + 1)
    except FileNotFoundError:
        raise InputError(label, str(path), "no such file") from None
    except OSError as err:
        raise InputError(label, str(path), f"cannot be read ({err.strerror})") from None
    if len(raw) > MAX_DOCUMENT_BYTES:
        why = f"is larger than {MAX_DOCUMENT_BYTES} bytes (a REST body's bound too)"
        raise InputError(label, str(path), why)
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise InputError(label, str(path), f"is not valid TOML ({err})") from None
