"""An API key's label is checked as a name is, at every surface; a stored bad one is shown safely.

A label with an ESC (terminal escape injection in ``rcb keys list``), a newline, a zero-width
space or more than 200 characters is refused naming ``--label``; one stored before the check
is listed with its control characters escaped, never written raw to the terminal.
"""

from __future__ import annotations

import json

import pytest
from sqlalchemy.orm import Session

from api.services.keys import create_key
from db import api_keys
from models.errors import InputError

from conftest import engine_url, invoke


@pytest.mark.parametrize(
    ("label", "reason"),
    [
        ("\x1b[31mred", "control characters (U+001B"),
        ("two\nlines", "control characters (U+000A"),
        ("zero\u200bwidth", "invisible format characters (U+200B"),
        ("x" * 201, "at most 200 characters"),
        ("x" * 100_000, "at most 200 characters"),
    ],
)
def test_cli_refuses_label(runner, engine, label, reason) -> None:
    url = engine_url(engine)
    done = invoke(runner, "keys", "create", "--role", "mes", "--label", label, "--db", url)
    assert done.exit_code == 2, done.output
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("rcb: error: --label = '"), lines
    assert reason in lines[0] and "\x1b" not in lines[0]
    listed = invoke(runner, "keys", "list", "--json", "--db", url)
    assert json.loads(listed.stdout)["keys"] == []


def test_service_refuses_label(engine) -> None:
    with pytest.raises(InputError, match="invisible format"):
        create_key(engine=engine, role="mes", label="a\u200b")


def test_label_normalised(runner, engine) -> None:
    url = engine_url(engine)
    done = invoke(runner, "keys", "create", "--role", "mes", "--label", " ＭＥＳ-1 ", "--db", url)
    assert done.exit_code == 0, done.output
    listed = invoke(runner, "keys", "list", "--json", "--db", url)
    assert [k["label"] for k in json.loads(listed.stdout)["keys"]] == ["MES-1"]
    assert create_key(engine=engine, role="mes")["id"] == 2  # no label: still allowed


def test_stored_bad_label_listed_safely(runner, engine) -> None:
    with Session(engine) as session, session.begin():
        api_keys.create_key(session=session, role="mes", label="\x1b[31mred\u200b")
    done = invoke(runner, "keys", "list", "--db", engine_url(engine))
    assert done.exit_code == 0, done.output
    assert "\x1b" not in done.stdout and "\u200b" not in done.stdout
    assert "\\x1b[31mred\\u200b" in done.stdout


def test_stored_long_label_listed_cut(runner, engine) -> None:
    """A 100 000-character label stored before the check filled 1 250 lines of the table."""
    with Session(engine) as session, session.begin():
        api_keys.create_key(session=session, role="mes", label="L" * 100_000)
    done = invoke(runner, "keys", "list", "--db", engine_url(engine))
    assert done.exit_code == 0, done.output
    assert done.stdout.count("L") == 199 and "…" in done.stdout  # 200 with the ellipsis
    listed = invoke(runner, "keys", "list", "--json", "--db", engine_url(engine))
    assert json.loads(listed.stdout)["keys"][0]["label"] == "L" * 100_000  # JSON: as stored
