"""A file of learned models: what ``rcb models export`` writes, ``import`` reads (issue 32).

A process engineer's review: a plant of 12 machines exported 480 models of one insert (1.25
MB) and ``rcb models import`` refused the file, larger than a REST body's 1 MiB. A file of
models has its own bound (:data:`models.bounds.MAX_MODELS_BYTES`), and export refuses to write
what import would refuse. The same review: ``rcb fleet law``'s catalogue column showed an
imported document's copy of the tool, not the catalogue a plan of this database starts from.
"""

from __future__ import annotations

import copy
import json
import uuid
from pathlib import Path

import pytest
from test_fleet_db import _learned
from test_fleet_import_once import _rows, _second

from api.cli.main import app
from api.services.fleet_models import export_tool, import_tool
from api.services.read.fleet import fleet_law
from models import bounds
from models.catalogue import catalogue

from conftest import engine_url


def _many(document: dict, least_bytes: int) -> dict:  # type: ignore[type-arg]
    """``document``'s models as if learned by other plants' plans, until it holds
    ``least_bytes`` as export writes it (each copy a plant of its own: other plans)."""
    out = {**document, "learned": []}
    while len(json.dumps(out, indent=1)) <= least_bytes:
        origin = str(uuid.uuid4())
        for item in copy.deepcopy(document["learned"]):
            item["origin"], item["plan"] = origin, f"{item['plan']}-{origin[:8]}"
            out["learned"].append(item)
    return out


def test_a_file_over_a_rest_body_is_imported_whole(engine, tmp_path: Path, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    document = _many(export_tool(engine=engine, tool="CNMG432RN"), bounds.MAX_DOCUMENT_BYTES)
    path = tmp_path / "plants.json"
    path.write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")
    assert path.stat().st_size > bounds.MAX_DOCUMENT_BYTES  # refused before: "larger than"
    second = _second(tmp_path)
    url = engine_url(second)
    done = runner.invoke(app, ["models", "import", str(path), "--db", url])
    assert done.exit_code == 0, done.output
    count = len(document["learned"])
    assert f"{count} learned models stored from plants.json ({count} new)" in done.output
    assert _rows(second) == count
    second.dispose()


def test_a_file_over_its_bound_is_refused_before_it_is_read(tmp_path: Path, runner) -> None:
    path = tmp_path / "huge.json"
    with path.open("wb") as file:
        file.truncate(bounds.MAX_MODELS_BYTES + 1)  # sparse: nothing written
    second = _second(tmp_path)
    done = runner.invoke(app, ["models", "import", str(path), "--db", engine_url(second)])
    assert done.exit_code == 2, done.output
    assert f"is larger than {bounds.MAX_MODELS_BYTES} bytes" in done.output
    assert "Traceback" not in done.output and _rows(second) == 0
    second.dispose()


def test_export_does_not_write_what_import_would_refuse(
    engine, tmp_path: Path, runner, monkeypatch
) -> None:
    _learned(engine, "fleet-a", 0, 2)
    out = tmp_path / "cnmg.json"
    args = ["models", "export", "CNMG432RN", "--out", str(out), "--db", engine_url(engine)]
    monkeypatch.setattr("api.cli.models.MAX_MODELS_BYTES", 1000)  # the bound, made small
    done = runner.invoke(app, args)
    assert done.exit_code == 2, done.output
    assert "TOOL = 'CNMG432RN': its 2 learned models make" in done.output
    assert "more than rcb models import reads (1000)" in done.output
    assert not out.exists()
    monkeypatch.undo()
    assert runner.invoke(app, args).exit_code == 0 and out.exists()


def test_export_writes_compact_json_where_indented_would_pass_the_bound(
    engine, tmp_path: Path, runner, monkeypatch
) -> None:
    """A year's plant (audited): a database that imported a 62 MB file (compact JSON) could not
    export the tool again: export wrote it indented, 1.3 x larger, and refused it."""
    _learned(engine, "fleet-a", 0, 2)
    document = export_tool(engine=engine, tool="CNMG432RN")
    compact = len(json.dumps(document, separators=(",", ":"))) + 1
    monkeypatch.setattr("api.cli.models.MAX_MODELS_BYTES", compact)  # under the indented size
    out = tmp_path / "cnmg.json"
    args = ["models", "export", "CNMG432RN", "--out", str(out), "--db", engine_url(engine)]
    done = runner.invoke(app, args)
    assert done.exit_code == 0, done.output
    assert out.stat().st_size == compact and json.loads(out.read_text()) == document
    monkeypatch.undo()
    assert runner.invoke(app, args).exit_code == 0
    assert b'\n "learned"' in out.read_bytes()  # under the bound: indented, for a reader


def test_the_fleet_law_sets_the_catalogue_of_this_database_beside_it(engine, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 2)
    document = export_tool(engine=engine, tool="CNMG432RN")
    for item in document["learned"]:  # another plant's copy of the insert's catalogue
        item["origin"] = str(uuid.uuid4())
        for model in item["tool"]["models"].values():
            model["K"] *= 2
    second = _second(tmp_path)
    assert import_tool(engine=second, data=document, source="edited.json").body["new"] == 2
    laws = fleet_law(engine=second, tool="CNMG432RN")["quantities"]
    packaged = catalogue()["CNMG432RN"].models
    shown = {law["quantity"]: law["catalogue_K"] for law in laws}
    assert shown and shown == {q: pytest.approx(packaged[q].K, rel=1e-9) for q in shown}
    second.dispose()


def test_a_file_saved_with_a_byte_order_mark_is_imported(engine, tmp_path: Path, runner) -> None:
    """A plant's engineer opened the export in Notepad and saved it: UTF-8 with a BOM, which
    ``rcb models import`` refused as "not valid JSON" (plan and tool files took it since
    650f6d9); UTF-16 is refused naming the encoding, nothing stored."""
    _learned(engine, "fleet-bom", 0, 2)
    text = json.dumps(export_tool(engine=engine, tool="CNMG432RN"), indent=1)
    second = _second(tmp_path)
    url = engine_url(second)
    wide = tmp_path / "wide.json"
    wide.write_text(text, encoding="utf-16")
    done = runner.invoke(app, ["models", "import", str(wide), "--db", url])
    assert (done.exit_code, _rows(second)) == (2, 0), done.output
    assert f"FILE = '{wide}': is UTF-16 or UTF-32 text" in done.output
    marked = tmp_path / "marked.json"
    marked.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    done = runner.invoke(app, ["models", "import", str(marked), "--db", url])
    assert done.exit_code == 0, done.output
    assert _rows(second) > 0
    second.dispose()
