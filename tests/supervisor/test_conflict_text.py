"""What a limit that cannot be met is said to need: never a number on the limit's own side."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from api.report.marks import halt_lines
from supervisor.errors import Conflict


@pytest.mark.parametrize(
    ("conflict", "text"),
    [
        # the usual case: 4 significant digits, as every message has said
        (
            Conflict("force_N", 2000.0, 2110.4, "max"),
            "force_N <= 2000 needs a limit of at least 2110",
        ),
        (
            Conflict("parts_per_edge", 40.0, 31.87, "min"),
            "parts_per_edge >= 40 can reach at most 31.87",
        ),
        # seen on 2026-12-06 (Hypothesis, test_setpoint_grid_rule.py): a program infeasible only
        # just said "force_N <= 127.303 needs a limit of at least 127.3"
        (
            Conflict("force_N", 127.303, 127.30312, "max"),
            "force_N <= 127.303 needs a limit of at least 127.3031",
        ),
        (
            Conflict("parts_per_edge", 10.0, 9.99996, "min"),
            "parts_per_edge >= 10 can reach at most 9.99996",
        ),
    ],
)
def test_the_limit_needed_is_shown_beyond_the_limit_given(conflict, text):
    assert conflict.describe() == text


def test_a_stored_halt_reads_as_the_error_did():
    halt = {
        "conflicts": [
            {
                "operation": "rough-od",
                "conflicts": [
                    {"name": "force_N", "limit": 127.303, "required": 127.30312, "sense": "max"}
                ],
                "held_by": [],
            }
        ]
    }
    assert halt_lines(halt) == ["rough-od: force_N <= 127.303 needs a limit of at least 127.3031"]


@settings(max_examples=300, deadline=None)
@given(
    limit=st.floats(1e-3, 1e6),
    excess=st.floats(1e-10, 10.0),
    sense=st.sampled_from(["max", "min"]),
)
def test_the_number_shown_lies_beyond_the_limit_shown(limit, excess, sense):
    required = limit * (1 + excess) if sense == "max" else limit / (1 + excess)
    shown_limit, shown = Conflict("q", limit, required, sense).texts()
    assert (
        float(shown) > float(shown_limit) if sense == "max" else float(shown) < float(shown_limit)
    )
    usual = (f"{limit:.6g}", f"{required:.4g}")
    if float(usual[1]) > float(usual[0]) if sense == "max" else float(usual[1]) < float(usual[0]):
        assert (shown_limit, shown) == usual  # 6 and 4 digits wherever they already say it
