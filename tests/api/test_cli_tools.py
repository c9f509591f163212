"""``rcb tools list``, ``show`` and ``add``: the tool library at the CLI, on SQLite and PostgreSQL.

Before, the CLI had no reader of the tools a plan may name, and a stored tool a later check
refuses could be defined anew under another name only through a plan file or ``POST /tools``.
The library's figures are Ivester & Heigel's (Table 2: CNMG432RN's force K = 2130 N, dK = 150
N, a 7.0 % band); the JSON is the REST service's (``GET /tools``), the same use cases.
"""

from __future__ import annotations

import json
import tomllib

import pytest
from sqlalchemy import select, update

from api.cli.main import app
from api.services.read.tools import get_tool, list_tools
from db import tables as t

from conftest import DEMO_PLAN, engine_url, invoke

TOOL_TOML = """\
name = "CNMG432-PLANT2"
process = "turning"
description = "CNMG432RN as plant 2's dynamometer measured it"
material = "AISI 1045 steel, cold rolled"
[models.force_N]
K = 2200
dK = 120
exponents = { depth_mm = 0.888, feed_mm_rev = 0.783, speed_m_min = -0.0395 }
reference = "plant 2 dynamometer, 2026-11"
"""


def _names(runner, url: str, limit: int) -> list[str]:
    """Every tool's name, page after page as ``rcb tools list --json`` chains them."""
    names: list[str] = []
    cursor: list[str] = []
    for _ in range(20):  # bounded: a few tools
        done = invoke(
            runner, "tools", "list", "--json", "--limit", str(limit), *cursor, "--db", url
        )
        assert done.exit_code == 0, done.stderr
        page = json.loads(done.stdout)
        assert len(page["tools"]) <= limit
        names += [tool["name"] for tool in page["tools"]]
        if page["next_cursor"] is None:
            return names
        cursor = ["--cursor", page["next_cursor"]]
    raise AssertionError("the pages did not end")


def test_a_tool_added_from_a_file_is_listed_shown_and_named_by_a_plan(runner, engine, tmp_path):
    url = engine_url(engine)
    catalogue = _names(runner, url, 100)
    assert catalogue == ["CNMG432RN", "CPGM32505", "VCMR331", "VPGR3305"]
    file = tmp_path / "plant2.toml"
    file.write_text(TOOL_TOML, encoding="utf-8")
    done = invoke(runner, "tools", "add", str(file), "--by", "ana", "--db", url)
    assert done.exit_code == 0, done.stderr
    assert "rcb: tool CNMG432-PLANT2 stored with its models of force_N" in done.stderr
    assert _names(runner, url, 2) == ["CNMG432-PLANT2", *catalogue]  # pages chain, code-point order
    done = invoke(runner, "tools", "show", "CNMG432-PLANT2", "--json", "--db", url)
    shown = json.loads(done.stdout)
    assert shown == get_tool(engine=engine, name="CNMG432-PLANT2")  # the REST service's JSON
    assert shown["models"]["force_N"]["K"] == 2200.0
    assert shown["source"] == "plant2.toml"  # where the models came from, unless the file says
    plan = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    plan["name"], plan["operations"][0]["tool"] = "plant2-part", "CNMG432-PLANT2"
    plan["operations"][0]["limits"] = {"force_N": 2000.0}  # plant 2 modelled the force alone
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps(plan), encoding="utf-8")
    done = invoke(runner, "plans", "create", str(plan_file), "--json", "--db", url)
    assert done.exit_code == 0, done.stderr
    history = json.loads(invoke(runner, "audit", "--json", "--db", url).stdout)["entries"]
    added = [(e["actor"], e["target"], e["result"]) for e in history if e["action"] == "add tool"]
    assert added == [("cli:ana", "tool CNMG432-PLANT2", "201")]


def test_show_prints_the_catalogue_models_and_their_bands(runner, engine):
    done = invoke(runner, "tools", "show", "CNMG432RN", "--db", engine_url(engine))
    assert done.exit_code == 0, done.stderr
    force = next(line for line in done.stdout.splitlines() if line.startswith("force_N"))
    # Ivester & Heigel Table 2: K 2130 N, dK 150 N, so a band of 7.0 %; depth exponent 0.888
    assert force.split()[:5] == ["force_N", "2130", "150", "7.0", "depth_mm=0.888"]
    assert "rcb: material: AISI 1045 steel, cold rolled" in done.stderr


def test_every_bad_add_is_one_line_naming_the_field_and_stores_nothing(runner, engine, tmp_path):
    url = engine_url(engine)
    cases = {
        "K = -1": ("K = 2200", "K = -1", "models.force_N.K = -1: must be greater than 0"),
        "catalogue name": (
            'name = "CNMG432-PLANT2"',
            'name = "CNMG432RN"',
            "name = 'CNMG432RN': a catalogue tool has this name",
        ),
        "unknown key": ("dK = 120", "dK = 120\nKK = 3", "models.force_N.KK"),
        # GET /tools/CNMG432%2FB routed as /tools/CNMG432/B: a tool no client could read
        "a slash": ('name = "CNMG432-PLANT2"', 'name = "CNMG432/B"', "name = 'CNMG432/B': a"),
        "dots": ('name = "CNMG432-PLANT2"', 'name = ".."', "name = '..': a tool's name is"),
        "not TOML": ("[models.force_N]", "[models.force_N", "is not valid TOML"),
    }
    for old, new, said in cases.values():
        file = tmp_path / "bad.toml"
        file.write_text(TOOL_TOML.replace(old, new), encoding="utf-8")
        done = invoke(runner, "tools", "add", str(file), "--db", url)
        assert done.exit_code == 2 and said in done.stderr, done.stderr
        assert len(done.stderr.splitlines()) == 1, done.stderr
    (tmp_path / "list.json").write_text("[1]", encoding="utf-8")
    done = invoke(runner, "tools", "add", str(tmp_path / "list.json"), "--db", url)
    assert done.exit_code == 2
    assert "FILE = " in done.stderr and "must hold a tool" in done.stderr
    assert len(list_tools(engine=engine)["tools"]) == 4  # the catalogue's alone: nothing stored
    good = tmp_path / "good.toml"
    good.write_text(TOOL_TOML, encoding="utf-8")
    assert invoke(runner, "tools", "add", str(good), "--db", url).exit_code == 0
    again = invoke(runner, "tools", "add", str(good), "--db", url)  # stored tools never change
    assert again.exit_code == 2
    assert "name = 'CNMG432-PLANT2': a tool of this name is already stored" in again.stderr
    for args in (["show", "NOPE"], ["list", "--limit", "0"], ["list", "--cursor", "zzz"]):
        done = invoke(runner, "tools", *args, "--db", url)
        assert done.exit_code == 2 and len(done.stderr.splitlines()) == 1, done.stderr
        assert done.stderr.startswith(("rcb: error: NAME = 'NOPE'", "rcb: error: --")), done.stderr


def test_a_stored_tool_a_later_check_refuses_is_listed_marked_with_the_way_out(
    runner, engine, tmp_path
):
    url = engine_url(engine)
    file = tmp_path / "plant2.toml"
    file.write_text(TOOL_TOML, encoding="utf-8")
    assert invoke(runner, "tools", "add", str(file), "--db", url).exit_code == 0
    with engine.begin() as c:  # what an older check let by: K must be above 0
        tool_id = c.execute(select(t.Tool.id).where(t.Tool.name == "CNMG432-PLANT2")).scalar_one()
        c.execute(update(t.ToolModel).values(K=-1.0).where(t.ToolModel.tool_id == tool_id))
    listed = invoke(runner, "tools", "list", "--db", url)
    assert listed.exit_code == 0, listed.stderr  # every other tool is still listed
    rows = [line.split() for line in listed.stdout.splitlines()]
    at = rows.index(next(row for row in rows if row and row[0] == "CNMG432-PLANT2"))
    assert rows[at + 1][0] == "REFUSED" and any(row and row[0] == "VPGR3305" for row in rows)
    shown = invoke(runner, "tools", "show", "CNMG432-PLANT2", "--db", url)
    assert shown.exit_code == 0, shown.stderr
    said = " ".join(shown.stderr.split())
    assert "rcb: REFUSED: tools.CNMG432-PLANT2.models.force_N.K = -1.0" in said
    assert "define it anew under another name" in said
    assert shown.stdout.splitlines()[3].split()[:2] == ["force_N", "-1"]  # as stored


def test_predict_takes_a_stored_tool_from_the_database_and_else_reads_none(
    runner, engine, tmp_path, monkeypatch
):
    url = engine_url(engine)
    file = tmp_path / "plant2.toml"
    file.write_text(TOOL_TOML, encoding="utf-8")
    assert invoke(runner, "tools", "add", str(file), "--db", url).exit_code == 0
    point = ["--depth-mm", "3", "--feed-mm-rev", "0.32", "--speed-m-min", "200"]
    args = ["predict", "--tool", "CNMG432-PLANT2", *point, "--json"]
    # Ivester & Heigel Eq. 5 with plant 2's K: F = 2200 · 3^0.888 · 0.32^0.783 · 200^-0.0395
    force_N = 2200 * 3**0.888 * 0.32**0.783 * 200**-0.0395
    for given, env in (([*args, "--db", url], {}), (args, {"RCB_DATABASE_URL": url})):
        done = runner.invoke(app, given, env=env)
        assert done.exit_code == 0, done.stderr
        predicted = json.loads(done.stdout)["predicted"]["force_N"]
        assert predicted["value"] == pytest.approx(force_N, rel=1e-12)
        assert predicted["band"] == pytest.approx(force_N * 120 / 2200, rel=1e-12)
    (elsewhere := tmp_path / "elsewhere").mkdir()  # the SQLite backend's file is tmp_path's
    monkeypatch.chdir(elsewhere)
    monkeypatch.delenv("RCB_DATABASE_URL", raising=False)
    done = invoke(runner, *args)  # no database named: the catalogue alone, no ./rcb.db made
    assert done.exit_code == 2
    assert "unknown tool" in done.stderr and "a stored tool: --db URL" in done.stderr
    assert list(elsewhere.iterdir()) == []
    catalogue = invoke(runner, "predict", "--tool", "CNMG432RN", *point, "--json")
    assert catalogue.exit_code == 0, catalogue.stderr  # Ivester & Heigel Table 2's K = 2130
    expected = 2130 * 3**0.888 * 0.32**0.783 * 200**-0.0395
    assert json.loads(catalogue.stdout)["predicted"]["force_N"]["value"] == pytest.approx(expected)


def test_optimize_and_certify_read_a_plan_naming_a_stored_tool_as_plans_create_does(
    runner, engine, tmp_path, monkeypatch
):
    """Before, both read the catalogue alone: a plan ``rcb plans create`` took was refused."""
    url = engine_url(engine)
    file = tmp_path / "plant2.toml"
    file.write_text(TOOL_TOML, encoding="utf-8")
    assert invoke(runner, "tools", "add", str(file), "--db", url).exit_code == 0
    plan = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    plan["name"], plan["operations"][0]["tool"] = "plant2-part", "CNMG432-PLANT2"
    plan["operations"][0]["limits"] = {"force_N": 2000.0}
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps(plan), encoding="utf-8")
    for given, env in ((["--db", url], {}), ([], {"RCB_DATABASE_URL": url})):
        done = runner.invoke(app, ["optimize", str(plan_file), "--json", *given], env=env)
        assert done.exit_code == 0, done.stderr
        rough = json.loads(done.stdout)["operations"][0]
        assert rough["tool"] == "CNMG432-PLANT2"
        d, f, v = (rough["setpoint"][k] for k in ("depth_mm", "feed_mm_rev", "speed_m_min"))
        # Ivester & Heigel Eq. 5 with plant 2's K and band: 2200 ± 120 N at the optimum
        force_N = 2200 * d**0.888 * f**0.783 * v**-0.0395
        predicted = rough["predicted"]["force_N"]
        assert predicted["value"] == pytest.approx(force_N, rel=1e-9)
        assert predicted["band"] == pytest.approx(force_N * 120 / 2200, rel=1e-9)
        assert predicted["value"] + predicted["band"] <= 2000.0 * (1 + 1e-9)
    args = ["certify", str(plan_file), "--scenarios", "2", "--parts", "2", "--jobs", "1"]
    done = invoke(runner, *args, "--json", "--db", url)
    assert done.exit_code == 0, done.stderr
    assert json.loads(done.stdout)["plan"] == "plant2-part"
    (elsewhere := tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(elsewhere)
    monkeypatch.delenv("RCB_DATABASE_URL", raising=False)
    for command in (["optimize", str(plan_file)], args):
        done = invoke(runner, *command)  # no database named: the catalogue alone, none made
        assert done.exit_code == 2, done.stderr
        assert "operations[0].tool = 'CNMG432-PLANT2': unknown tool" in done.stderr
        assert "a stored tool: --db URL (rcb tools list)" in done.stderr
    assert list(elsewhere.iterdir()) == []


def test_a_plan_files_tools_block_of_one_tool_is_that_tool_and_more_are_one_short_line(
    runner, engine, tmp_path
):
    """Before: ``tools = [{...the whole dict...}]: unknown field; ...`` (270 columns)."""
    url = engine_url(engine)
    wrapped = tmp_path / "wrapped.toml"  # the block as a plan file has it, copied whole
    block = TOOL_TOML.replace("[models.", "[tools.models.")
    wrapped.write_text("[[tools]]\n" + block, encoding="utf-8")
    done = invoke(runner, "tools", "add", str(wrapped), "--db", url)
    assert done.exit_code == 0, done.stderr
    assert "rcb: tool CNMG432-PLANT2 stored with its models of force_N" in done.stderr
    as_json = tmp_path / "wrapped.json"
    tool = tomllib.loads(TOOL_TOML) | {"name": "CNMG432-PLANT3"}
    as_json.write_text(json.dumps({"tools": [tool]}), encoding="utf-8")
    assert invoke(runner, "tools", "add", str(as_json), "--db", url).exit_code == 0
    two = tmp_path / "two.toml"
    two.write_text(f"[[tools]]\n{block}\n[[tools]]\n{block.replace('PLANT2', 'P4')}", "utf-8")
    plan = tmp_path / "plan.toml"
    plan.write_text(DEMO_PLAN.read_text(encoding="utf-8") + "\n[[tools]]\n" + block, "utf-8")
    for file, said in (
        (two, f"FILE = '{two}': holds 2 tools; a tool file holds one (a file each)"),
        (plan, f"FILE = '{plan}': is a plan file, not a tool (name, process, models)"),
        # a first-day review: the example plan (catalogue tools only) was its machine table
        # echoed as an unknown field of a tool
        (DEMO_PLAN, f"FILE = '{DEMO_PLAN}': is a plan file, not a tool (name, process, models)"),
    ):
        done = invoke(runner, "tools", "add", str(file), "--db", url)
        assert done.exit_code == 2 and done.stderr == f"rcb: error: {said}\n", done.stderr
    names = [tool["name"] for tool in list_tools(engine=engine)["tools"]]
    assert "CNMG432-P4" not in names and {"CNMG432-PLANT2", "CNMG432-PLANT3"} <= set(names)
