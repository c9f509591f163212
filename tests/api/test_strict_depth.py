"""The depth check of a JSON body (:func:`api.rest.strict.loads`) without the service.

The walk of every body's containers is skipped when the body has no more opening brackets
than :data:`~api.rest.strict.MAX_DEPTH` (a part report has about 30): the skip must never let
a deeper document through, whatever its strings hold.
"""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from api.rest.problems import ProblemError
from api.rest.strict import MAX_DEPTH, _depth, _may_nest_deeper, loads

_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.text(alphabet='{[]}a"\\', max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner),
    max_leaves=80,
)


def _nested(levels: int) -> bytes:
    return b"[" * levels + b"]" * levels


@given(_JSON)
@settings(max_examples=300)
def test_the_bracket_count_never_skips_a_document_too_deep(document):
    body = json.dumps(document).encode()
    assert _may_nest_deeper(body) or _depth(document) <= MAX_DEPTH


@given(st.integers(min_value=1, max_value=3 * MAX_DEPTH))
@settings(max_examples=100)
def test_depth_is_the_nesting_of_arrays_and_objects(levels):
    assert _depth(json.loads(_nested(levels))) == levels
    assert _depth(json.loads(b'{"a":' * levels + b"1" + b"}" * levels)) == levels


def test_a_body_at_the_limit_is_read_and_one_level_more_refused():
    assert _depth(loads(_nested(MAX_DEPTH))) == MAX_DEPTH
    with pytest.raises(ProblemError) as caught:
        loads(_nested(MAX_DEPTH + 1))
    assert (caught.value.status, caught.value.code) == (400, "malformed_json")
    assert f"more than {MAX_DEPTH} levels deep" in caught.value.detail


def test_brackets_in_strings_count_but_do_not_nest():
    body = json.dumps({"a": "[" * 200, "b": [[1]]}).encode()
    assert _may_nest_deeper(body)  # the walk runs, and finds the truth
    assert _depth(loads(body)) == 3
