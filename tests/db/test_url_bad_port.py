"""A database URL whose port is not a port: one line naming the field and the URL.

Before, SQLAlchemy's ``int()`` of the text after the host's last ``:`` raised ``ValueError:
invalid literal for int()`` out of every command, through ``--db`` and ``RCB_DATABASE_URL``.
"""

from __future__ import annotations

import pytest

from db.urls import check
from models.errors import InputError

from conftest import invoke

REASON = (
    "the port after the host must be a whole number from 1 to 65535 "
    "(host:5432; an IPv6 address in brackets, [::1]:5432)"
)
BAD = [
    ("postgresql+psycopg://postgres@127.0.0.1:notaport/x", None),
    ("postgresql+psycopg://postgres@[::1/x", None),
    (
        "postgresql+psycopg://postgres:pw@127.0.0.1:notaport/x",
        "postgresql+psycopg://postgres:***@127.0.0.1:notaport/x",
    ),
    (
        "postgresql+psycopg://postgres:p@w@127.0.0.1:x/x",
        "postgresql+psycopg://postgres:***@127.0.0.1:x/x",
    ),
    (
        "postgresql+psycopg://postgres:pw@127.0.0.1:70000/x",
        "postgresql+psycopg://postgres:***@127.0.0.1:70000/x",
    ),
]


@pytest.mark.parametrize(("url", "shown"), BAD)
def test_check_refuses_a_port_that_is_not_one(url, shown):
    with pytest.raises(InputError) as caught:
        check(url, "RCB_DATABASE_URL")
    assert str(caught.value) == f"RCB_DATABASE_URL = {shown or url!r}: {REASON}"


@pytest.mark.parametrize(("url", "shown"), BAD[:3])
@pytest.mark.parametrize(
    "command", [["keys", "list"], ["db", "upgrade"], ["serve"], ["plans"]], ids=" ".join
)
def test_every_command_says_one_line(runner, monkeypatch, url, shown, command):
    done = invoke(runner, *command, "--db", url)
    assert (done.exit_code, done.stderr) == (2, f"rcb: error: --db = {shown or url!r}: {REASON}\n")
    monkeypatch.setenv("RCB_DATABASE_URL", url)
    done = invoke(runner, *command)
    assert (done.exit_code, done.stderr) == (
        2,
        f"rcb: error: RCB_DATABASE_URL = {shown or url!r}: {REASON}\n",
    )
