"""A refused argument is named as rcb names arguments: its metavar (``ID``), else its name.

``rcb keys revoke abc`` said ``value = 'abc': must be a whole number``: typer's arguments have
no ``human_readable_name``, and :func:`api.cli.usage_words.param_name` fell back to ``value``.
"""

from __future__ import annotations

from types import SimpleNamespace

import click
import pytest
from pydantic import TypeAdapter, ValidationError

from api.cli.main import app
from api.cli.usage_words import said


def test_keys_revoke_names_its_id_argument(runner, tmp_path):
    result = runner.invoke(app, ["keys", "revoke", "abc", "--db", f"sqlite:///{tmp_path / 'n.db'}"])
    assert result.exit_code == 2, result.output
    assert result.stderr == "rcb: error: ID = 'abc': must be a whole number\n"
    assert not (tmp_path / "n.db").exists()  # refused before anything was opened


def _usage_error(param: object) -> click.BadParameter:
    """A usage error of ``param`` caused by pydantic's refusal of ``'abc'`` as an int."""
    try:
        TypeAdapter(int).validate_python("abc")
    except ValidationError as cause:
        err = click.BadParameter("refused")
        err.param = param  # type: ignore[assignment]
        err.__cause__ = cause
        return err
    raise AssertionError("pydantic took 'abc' as an int")


@pytest.mark.parametrize(
    ("metavar", "name"), [("ID", "ID"), (None, "KEY_ID")], ids=["metavar", "no-metavar"]
)
def test_an_argument_is_named_by_its_metavar_else_its_name(metavar, name):
    # as typer (0.29) makes an argument: opts its name, no human_readable_name
    param = SimpleNamespace(
        opts=["key_id"], human_readable_name=None, metavar=metavar, name="key_id"
    )
    assert said(_usage_error(param)) == f"{name} = 'abc': must be a whole number"
