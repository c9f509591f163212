"""A plan named at the CLI is looked up as REST compares names (NFKC, no white space around).

``rcb history ' ivester-demo-part '`` and ``--plan`` in full-width letters answered "no plan
named" though the plan exists; a name with a control or invisible character is refused
saying so, one line, before the database is asked.
"""

from __future__ import annotations

import json

import pytest

from conftest import DEMO_PLAN, engine_url, invoke

FULL_WIDTH = "ｉｖｅｓｔｅｒ-demo-part"


@pytest.fixture
def url(runner, engine) -> str:
    url = engine_url(engine)
    created = invoke(runner, "plans", "create", str(DEMO_PLAN), "--db", url)
    assert created.exit_code == 0, created.output
    return url


@pytest.mark.parametrize("name", [" ivester-demo-part ", FULL_WIDTH])
def test_a_plan_name_is_normalised(runner, url, name) -> None:
    done = invoke(runner, "history", name, "--json", "--db", url)
    assert done.exit_code == 0, done.output
    key = invoke(runner, "keys", "create", "--role", "mes", "--plan", name, "--json", "--db", url)
    assert key.exit_code == 0, key.output
    assert json.loads(key.stdout)["plans"] == [1]


def test_an_invisible_character_is_refused(runner, url) -> None:
    done = invoke(runner, "history", "ivester-demo\u200b-part", "--db", url)
    assert done.exit_code == 2
    assert done.stderr.splitlines() == [
        "rcb: error: PLAN = 'ivester-demo\\u200b-part': a plan's name must not contain invisible "
        "format characters (U+200B ZERO WIDTH SPACE at 12)"
    ]
