"""An option's value typer refuses is said in rcb's words (:mod:`api.cli.usage_words`).

typer 0.29 coerces values with pydantic, and ``rcb plans list --limit abc`` said ``Invalid value
for '--limit': Input should be a valid integer, unable to parse string as an integer (got
'abc')``; every other error of rcb says ``OPTION = VALUE: what it must be``.
"""

from __future__ import annotations

import pytest
from pydantic import BaseModel, ValidationError, conint

from api.cli.main import app
from api.cli.usage_words import said

#: What pydantic and click say, which no usage error may.
FOREIGN = ("Input should", "Value error", "Invalid value for", "pydantic", "Traceback")


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (["plans", "list", "--limit", "abc"], "--limit = 'abc': must be a whole number"),
        (["plans", "list", "--limit", "1.5"], "--limit = 1.5: must be a whole number"),
        (["demo", "--parts", "5000"], "--parts = 5000: must be at most 1000"),
        (["demo", "--seed", "-1"], "--seed = -1: must be at least 0"),
        (["demo", "--alpha", "abc"], "--alpha = 'abc': must be a number"),
        (["demo", "--alpha", "nan"], "--alpha = nan: must be a number in (0, 1]"),
        (["report", "1", "--last", "0"], "--last = 0: must be at least 1"),
        (["audit", "--limit", "x y"], "--limit = 'x y': must be a whole number"),
    ],
)
def test_a_refused_value_is_one_line_in_rcbs_words(runner, tmp_path, args, line):
    result = runner.invoke(app, [*args, "--db", f"sqlite:///{tmp_path / 'none.db'}"])
    assert result.exit_code == 2, result.output
    assert result.stderr == f"rcb: error: {line}\n"
    assert not any(word in result.stderr for word in FOREIGN)
    assert not (tmp_path / "none.db").exists()  # refused before anything was opened


class _Bounded(BaseModel):
    n: conint(ge=2, le=9)  # type: ignore[valid-type]


class _Refused(Exception):
    param = None


def _error_from(value: object) -> _Refused:
    refused = _Refused()
    try:
        _Bounded(n=value)
    except ValidationError as err:
        refused.__cause__ = err
    return refused


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("abc", "value = 'abc': must be a whole number"),
        ("12", "value = 12: must be at most 9"),
        (" 1", "value = ' 1': must be at least 2"),  # a numeral with a space is quoted
    ],
)
def test_said_words_pydantics_errors(value, words):
    assert said(_error_from(value)) == words


def test_said_leaves_other_errors_alone():
    assert said(ValueError("x")) is None
