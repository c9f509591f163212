"""Two refusals said as what they are: a long age is too long, a directory is not a database.

``rcb db prune --audit-older-than 99999999999d`` said ``expected a whole number and d, h or
m``, though it is one (more than nine digits failed the pattern); ``36501d`` already said
``at most 36500d``. ``--db sqlite:///.`` (any existing directory) said ``no such database
file`` or ``does the directory ... exist?``: it does, and it is not a file.
"""

from __future__ import annotations

import pytest

from api.services.retention import parse_duration
from models.errors import InputError

from conftest import invoke

TOO_LONG = "more than 0 and at most 36500d"


@pytest.mark.parametrize("age", ["99999999999d", "36501d", "999999999999999999999999h", "0d"])
def test_a_too_long_age_says_its_bound(runner, tmp_path, age):
    url = f"sqlite:///{tmp_path / 'r.db'}"
    invoke(runner, "db", "upgrade", "--db", url)
    done = invoke(runner, "db", "prune", "--audit-older-than", age, "--db", url)
    assert (done.exit_code, done.stderr) == (
        2,
        f"rcb: error: --audit-older-than = {age!r}: {TOO_LONG}\n",
    )


def test_leading_zeros_are_a_whole_number():
    assert parse_duration("--x", "0000000000000365d").days == 365
    with pytest.raises(InputError, match="expected a whole number"):
        parse_duration("--x", "1y")


@pytest.mark.parametrize(
    "command", [["keys", "list"], ["db", "upgrade"], ["keys", "create", "--role", "mes"], ["serve"]]
)
@pytest.mark.parametrize("relative", [True, False], ids=["dot", "absolute"])
def test_a_directory_is_not_a_database_file(runner, tmp_path, monkeypatch, command, relative):
    monkeypatch.chdir(tmp_path)
    url = "sqlite:///." if relative else f"sqlite:///{tmp_path}"
    done = invoke(runner, *command, "--db", url)
    assert (done.exit_code, done.stderr) == (
        2,
        f"rcb: error: --db = {url!r}: is a directory, not a database file; "
        f"give a file in it, e.g. sqlite:///{tmp_path / 'rcb.db'}\n",
    )
    assert list(tmp_path.iterdir()) == []  # nothing created
