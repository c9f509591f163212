"""A cursor is refused by name (InputError on ``cursor``, a 422 over REST) when its text is no
text a database can hold: a lone surrogate (``["\\ud800"]``, base64url) made a 500 on ``GET
/tools`` and ``GET /tools/{name}/fleet/imported`` (an integrator's review, 2026-12-02: the
driver could not encode it, and the server then dropped the keep-alive connection)."""

from __future__ import annotations

import base64
import json
from typing import Any

import pytest

from api.services.read.common import _token, _untoken
from api.services.read.fleet import imported_fleet
from api.services.read.tools import list_tools
from models.errors import InputError


def _cursor(values: list[Any]) -> str:
    text = json.dumps(values)  # ASCII escapes: "\ud800" stays a lone surrogate when decoded
    return base64.urlsafe_b64encode(text.encode("ascii")).decode("ascii").rstrip("=")


@pytest.mark.parametrize(
    ("read", "values"),
    [
        (lambda engine, c: list_tools(engine=engine, cursor=c), ["\ud800"]),
        (lambda engine, c: list_tools(engine=engine, cursor=c), ["a\udfffb"]),
        (
            lambda engine, c: imported_fleet(engine=engine, tool="CNMG432RN", cursor=c),
            ["\ud800", "x"],
        ),
    ],
)
def test_a_cursor_of_a_lone_surrogate_is_refused_by_name(engine, read, values) -> None:
    cursor = _cursor(values)
    with pytest.raises(InputError) as refused:
        read(engine, cursor)
    assert (refused.value.field, refused.value.value) == ("cursor", cursor)


def test_a_cursor_of_any_other_text_round_trips() -> None:
    for name in ("CNMG432RN", "Ｍ-ＴＯＯＬ", "ä\u200fé", "x" * 200):
        assert _untoken(_token([name]), 1) == [name]
