"""Reading the files the supervisor takes (plan files, domain files); errors name the file.

A plan file is TOML or, named ``*.json``, JSON (the structure ``POST /api/v1/plans`` takes):
:func:`read_document` reads either. Every command that reads a plan file reads it so, through
:func:`supervisor.inputs.plan.read_plan` (``rcb optimize``, ``demo --plan``, ``certify``,
``plans create``); ``rcb tools add`` reads a tool file with it too.
"""

from __future__ import annotations

import json
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
        bound: checked before the file is parsed), not UTF-8 text (:func:`_text`) or not TOML;
        the field is ``label``, the value the path.
    """
    text = _text(_read(path, label), path, label)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(label, str(path), f"is not valid TOML ({err})") from None


def read_document(path: Path, label: str) -> object:
    """The parsed file at ``path``: ``.json`` (any case) as JSON, anything else as TOML.

    Raises
    ------
    InputError
        As :func:`read_toml`; a ``.json`` file as :func:`read_json`.
    """
    if path.suffix.lower() != ".json":
        return read_toml(path, label)
    return read_json(path, label)


def read_json(path: Path, label: str, most: int = MAX_DOCUMENT_BYTES) -> object:
    """The parsed JSON file at ``path``, of at most ``most`` bytes.

    Raises
    ------
    InputError
        As :func:`read_toml`, over ``most`` bytes, or not JSON; naming ``label`` and the path.
    """
    text = _text(_read(path, label, most), path, label)
    try:
        return json.loads(text)
    except ValueError as err:
        raise InputError(label, str(path), f"is not valid JSON ({err})") from None


def _read(path: Path, label: str, most: int = MAX_DOCUMENT_BYTES) -> bytes:
    """The bytes of ``path``, at most ``most`` of them."""
    try:
        with path.open("rb") as file:
            raw = file.read(most + 1)
    except FileNotFoundError:
        raise InputError(label, str(path), "no such file") from None
    except OSError as err:
        raise InputError(label, str(path), f"cannot be read ({err.strerror})") from None
    if len(raw) > most:
        also = " (a REST body's bound too)" if most == MAX_DOCUMENT_BYTES else ""
        raise InputError(label, str(path), f"is larger than {most} bytes{also}")
    return raw


#: The byte-order marks of UTF-16 and UTF-32 text ("Unicode" in some editors' save dialogs).
_WIDE_BOMS = (b"\xff\xfe", b"\xfe\xff")


def _text(raw: bytes, path: Path, label: str) -> str:
    """``raw`` as UTF-8 text; a UTF-8 byte-order mark (as Windows editors save) is dropped.

    Text in another encoding is refused naming where the first byte UTF-8 cannot read is, by
    line and column, and what to do: an editor shows nothing wrong at the start of a file
    whose mark the parser trips on, or in a line whose accent is Latin-1.
    """
    if raw.startswith(_WIDE_BOMS):
        why = "is UTF-16 or UTF-32 text (a byte-order mark FF FE or FE FF): save it as UTF-8"
        raise InputError(label, str(path), why)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        before = raw[: err.start]
        line = before.count(b"\n") + 1
        column = err.start - (before.rfind(b"\n") + 1) + 1
        why = (
            f"is not UTF-8 text (byte 0x{raw[err.start]:02x} at line {line}, column {column}):"
            " save it as UTF-8"
        )
        raise InputError(label, str(path), why) from None
