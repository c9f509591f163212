"""The plan reader, the one path a plan takes from TOML, JSON and REST (issue 31, item 3).

Its errors are gathered by part (name, machine, each inline tool, each operation), so a plan
with several is refused with every one; a JSON ``null`` of an optional field is the field left
out; text no database column can hold is refused here, not by a schema in front of it.
"""

from __future__ import annotations

import copy
import json
import tomllib

import pytest

from models.errors import InputError, InputErrors
from models.tool import tool_body
from supervisor.inputs.plan import load_plan, plan_body, plan_from_mapping

from conftest import DEMO_PLAN, step1_plan


def _broken() -> dict:
    """Step 1 with four independent errors: the machine's power, a tool's K, two operations."""
    plan = step1_plan()
    plan["machine"]["max_power_kW"] = -22
    plan["tools"] = [
        {"name": "T-ok", "process": "turning", "models": {"force_N": {"K": 1000}}},
        {"name": "T-bad", "process": "turning", "models": {"force_N": {"K": "big"}}},
    ]
    second = copy.deepcopy(plan["operations"][0])
    second["name"], second["volume_mm3"] = "finish-od", 0
    plan["operations"][0]["limits"]["force_N"] = True
    plan["operations"].append(second)
    return plan


def test_every_independent_error_of_a_plan_is_named_at_once():
    plan = _broken()
    with pytest.raises(InputErrors) as caught:
        plan_from_mapping(plan)
    fields = [e.field for e in caught.value.errors]
    # the operations are read once the machine and tools they use were: fixed, they are read
    assert fields == ["machine.max_power_kW", "tools[1].models.force_N.K"]
    plan["machine"]["max_power_kW"] = 22
    plan["tools"].pop()
    with pytest.raises(InputErrors) as caught:
        plan_from_mapping(plan)
    assert [(e.field, e.value) for e in caught.value.errors] == [
        ("operations[0].limits.force_N", True),
        ("operations[1].volume_mm3", 0),
    ]
    # the first error is the error's own field, value and message line
    assert (caught.value.field, caught.value.value) == ("operations[0].limits.force_N", True)
    assert str(caught.value).splitlines() == [str(e) for e in caught.value.errors]


def test_one_error_is_raised_as_itself():
    plan = step1_plan()
    plan["operations"][0]["volume_mm3"] = -1
    with pytest.raises(InputError) as caught:
        plan_from_mapping(plan)
    assert type(caught.value) is InputError
    assert str(caught.value) == "operations[0].volume_mm3 = -1: must be greater than 0"


def test_a_name_given_twice_is_named_with_the_other_errors():
    plan = step1_plan()
    plan["operations"].append(copy.deepcopy(plan["operations"][0]))
    plan["name"] = "\x00"
    with pytest.raises(InputErrors) as caught:
        plan_from_mapping(plan)
    assert [(e.field, e.reason) for e in caught.value.errors] == [
        ("name", "must not contain NUL characters"),
        ("operations[1].name", "duplicate operation name"),
    ]


def test_the_same_plan_reads_the_same_from_toml_and_json(tmp_path):
    plan = _broken()
    with pytest.raises(InputErrors) as from_json:
        plan_from_mapping(plan)
    toml = tmp_path / "plan.toml"
    toml.write_text(_as_toml(plan), encoding="utf-8")
    assert tomllib.loads(toml.read_text(encoding="utf-8")) == plan
    with pytest.raises(InputErrors) as from_toml:
        load_plan(toml)
    assert [str(e) for e in from_toml.value.errors] == [str(e) for e in from_json.value.errors]


def test_load_plan_reads_a_json_file_by_its_extension_as_plans_create_does(tmp_path):
    """``rcb optimize plan.json`` said "is not valid TOML": load_plan read every file as TOML."""
    plan = step1_plan()
    as_json = tmp_path / "plan.JSON"
    as_json.write_text(json.dumps({**plan, "description": None}), encoding="utf-8")  # null: out
    assert load_plan(as_json) == plan_from_mapping(plan)
    as_json.write_text("{not json", encoding="utf-8")
    with pytest.raises(InputError, match=r"^plan file = '.*plan.JSON': is not valid JSON \("):
        load_plan(as_json)


def test_a_file_saved_with_a_byte_order_mark_is_read_and_other_encodings_are_named(tmp_path):
    """A UTF-8 BOM (Windows Notepad) was "not valid TOML (Invalid statement (at line 1, column
    1))", where an editor shows nothing; UTF-16 and Latin-1 text said a codec's words."""
    text = DEMO_PLAN.read_text(encoding="utf-8")
    plan = tomllib.loads(text)
    toml, as_json = tmp_path / "plan.toml", tmp_path / "plan.json"
    toml.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    as_json.write_bytes(b"\xef\xbb\xbf" + json.dumps(plan).encode("utf-8"))
    assert load_plan(toml) == load_plan(as_json) == plan_from_mapping(plan)
    toml.write_bytes(text.encode("utf-16"))  # a BOM, then two bytes a character
    with pytest.raises(InputError) as wide:
        load_plan(toml)
    assert str(wide.value) == (
        f"plan file = {str(toml)!r}: is UTF-16 or UTF-32 text (a byte-order mark FF FE or FE"
        " FF): save it as UTF-8"
    )
    toml.write_bytes('name = "step-1"\ndescription = "caf\u00e9"\n'.encode("latin-1"))
    with pytest.raises(InputError) as latin:
        load_plan(toml)
    # é is 0xe9 in Latin-1, the 19th character of line 2 (18 before it: description = "caf)
    assert str(latin.value) == (
        f"plan file = {str(toml)!r}: is not UTF-8 text (byte 0xe9 at line 2, column 19):"
        " save it as UTF-8"
    )


def test_a_null_optional_field_is_one_left_out_and_a_null_value_is_refused():
    plan = step1_plan()
    plan.update(description=None, tools=None, rcb=None)
    plan["machine"].update(max_spindle_rpm=None, calibrations=None)
    plan["operations"][0].update(catalog_setpoint=None, objective=None, stock_mm=None)
    body = plan_body(plan)
    assert body == {**step1_plan(), "machine": {"name": "lathe-22kW", "max_power_kW": 22}}
    assert plan_from_mapping(body).machine.limits() == {"power_kW": 22.0}
    plan["operations"][0]["limits"]["force_N"] = None  # a limit of null is no number
    with pytest.raises(InputError, match=r"operations\[0\].limits.force_N: must be a num"):
        plan_from_mapping(plan_body(plan))


def test_a_tool_s_null_fields_and_its_models_are_left_out():
    tool = {"name": "T", "process": "turning", "material": None,
            "models": {"force_N": {"K": 900, "dK": None, "source": None}}}  # fmt: skip
    assert tool_body(tool) == {"name": "T", "process": "turning", "models": {"force_N": {"K": 900}}}


@pytest.mark.parametrize("text", ["a\x00b", "a\ud800b"])
def test_text_no_column_can_hold_is_refused_by_the_reader(text):
    plan = step1_plan()
    plan["description"] = text
    with pytest.raises(InputError, match="^description = .*: must (not contain NUL|be valid Uni)"):
        plan_from_mapping(plan)


def test_names_are_compared_as_stored_in_every_surface():
    """A full-width tool name and machine name are NFKC-normalised, as REST's schema did."""
    plan = step1_plan()
    plan["operations"][0]["tool"] = "ＣＮＭＧ432RN"
    plan["machine"]["name"] = " lathe-22kW "
    read = plan_from_mapping(plan)
    assert (read.operations[0].tool, read.machine.name) == ("CNMG432RN", "lathe-22kW")
    assert list(read.tools) == ["CNMG432RN"]


def _as_toml(plan: dict) -> str:
    """``plan`` as a TOML plan file (the few shapes step 1 and its tools use)."""

    def value(v: object) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v + '"'
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        return repr(v)

    lines = [f"{k} = {value(v)}" for k, v in plan.items() if not isinstance(v, dict | list)]
    lines.append(f"machine = {value(plan['machine'])}")
    for key in ("tools", "operations"):
        lines += [f"\n[[{key}]]\n" + "\n".join(f"{k} = {value(v)}" for k, v in entry.items())
                  for entry in plan[key]]  # fmt: skip
    return "\n".join(lines) + "\n"


def test_a_file_of_another_kind_is_refused_by_its_first_unknown_key_alone():
    """A domain file given as a plan: its first key, not also every table a plan lacks."""
    with pytest.raises(InputError) as caught:
        plan_from_mapping({"cut": {"axial_depth_mm": 2}, "domain": {}})
    assert type(caught.value) is InputError
    assert (caught.value.field, caught.value.value) == ("cut", {"axial_depth_mm": 2})
