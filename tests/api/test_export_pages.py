"""rcb export streams: a page of parts and of versions at a time, each file whole or not at all.

A plan of 30 parts is exported in pages of 7 (the read services' page size made small) and
the files compared byte for byte (csv) and value for value (parquet) with the tables made from
every part and version at once: the page boundaries leave no trace. A note and a flag stored on
a late part's decision (pages before it have none) keep the parquet columns' types. A disk
that fills half-way leaves the files that were there as they were and no temporary file.
"""

from __future__ import annotations

import errno

import pandas as pd
import pyarrow.parquet as pq
import pytest
from sqlalchemy import select, update
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli import atomic
from api.cli.main import app
from api.report import export as tidy
from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read import history as read_history
from api.services.read import plan_parts as read_parts
from db import tables as t
from db.engine import make_engine
from supervisor.rcb.state import RcbSettings

from migrated import migrated

PARTS = 30
NOTE = "=checked the insert"  # a formula cell too: neutralised in csv, kept in parquet


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    root = tmp_path_factory.mktemp("export_pages")
    url = f"sqlite:///{root / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    bayes = RcbSettings("bayes")  # a setpoint version per part: 31 versions
    plan_id = create_plan(engine=engine, body=BODY, settings=bayes).body["id"]
    bodies, _ = _reports(PARTS, settings=bayes)
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    with Session(engine) as session, session.begin():
        late = session.scalar(select(t.Part.id).where(t.Part.serial == "SN-0027"))
        first = session.scalar(select(t.RcbDecision.id).where(t.RcbDecision.part_id == late))
        session.execute(
            update(t.RcbDecision)
            .where(t.RcbDecision.id == first)
            .values(note=NOTE, flagged=True, flag="sensor")
        )
    whole = {
        **tidy.part_frames(plan_id, queries.all_parts(engine=engine, plan_id=plan_id)),
        "setpoints": tidy.setpoint_frame(
            queries.full_history(engine=engine, plan_id=plan_id)["versions"]
        ),
    }
    engine.dispose()
    return url, plan_id, root, whole


@pytest.fixture
def pages_of_7(monkeypatch):
    monkeypatch.setattr(read_parts, "MAX_PAGE", 7)
    monkeypatch.setattr(read_history, "MAX_PAGE", 7)


def _export(runner, url, plan_id, out, fmt):
    args = ["export", str(plan_id), "--format", fmt, "--out", str(out), "--db", url]
    return runner.invoke(app, args)


def test_csv_in_pages_is_the_table_made_at_once(runner, stored, pages_of_7, tmp_path):
    url, plan_id, _, whole = stored
    result = _export(runner, url, plan_id, tmp_path, "csv")
    assert result.exit_code == 0, result.output
    for name, frame in whole.items():
        assert (tmp_path / f"{name}.csv").read_bytes() == tidy.csv_bytes(frame), name
    assert len(whole["parts"]) == PARTS and len(whole["setpoints"]) == (PARTS + 1) * 6
    noted = pd.read_csv(tmp_path / "decisions.csv").dropna(subset=["note"])
    assert list(noted.note) == ["'" + NOTE] and list(noted.serial) == ["SN-0027"]


def test_parquet_in_pages_keeps_values_and_types(runner, stored, pages_of_7, tmp_path):
    url, plan_id, _, whole = stored
    result = _export(runner, url, plan_id, tmp_path, "parquet")
    assert result.exit_code == 0, result.output
    for name, frame in whole.items():
        read = pd.read_parquet(tmp_path / f"{name}.parquet")
        pd.testing.assert_frame_equal(_cells(read), _cells(frame), check_dtype=False, obj=name)
    decisions = pq.ParquetFile(tmp_path / "decisions.parquet")
    assert decisions.metadata.num_row_groups == 5  # 30 parts in pages of 7
    schema = decisions.schema_arrow
    assert str(schema.field("note").type) == "string"  # though the first pages have no note
    assert str(schema.field("flagged").type) == "bool"
    parts = pq.ParquetFile(tmp_path / "parts.parquet").schema_arrow
    assert str(parts.field("received_at").type) == "timestamp[us, tz=UTC]"
    noted = pd.read_parquet(tmp_path / "decisions.parquet").dropna(subset=["note"])
    assert list(noted.note) == [NOTE] and list(noted.flag) == ["sensor"]


def _cells(frame: pd.DataFrame) -> pd.DataFrame:
    """Each cell as a Python value, a missing one as None (a typed column's NaN, a list's None)."""
    return frame.astype(object).where(frame.notna(), None)


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_a_full_disk_half_way_leaves_the_old_files(
    runner, stored, pages_of_7, tmp_path, fmt, monkeypatch
):
    url, plan_id, _, _ = stored
    for name in ("parts", "setpoints"):
        (tmp_path / f"{name}.{fmt}").write_bytes(b"the export before")
    writes = {"n": 0}

    def full(*args, **kwargs):
        writes["n"] += 1
        if writes["n"] > 6:  # past the first pages
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(*args, **kwargs)

    if fmt == "csv":
        real = atomic.AtomicFile.write
        monkeypatch.setattr(atomic.AtomicFile, "write", full)
    else:
        real = pq.ParquetWriter.write_table
        monkeypatch.setattr(pq.ParquetWriter, "write_table", full)
    result = _export(runner, url, plan_id, tmp_path, fmt)
    assert result.exit_code == 2, result.output
    assert "cannot be written (No space left on device)" in result.stderr
    assert "Traceback" not in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"parts.{fmt}", f"setpoints.{fmt}"]
    for name in ("parts", "setpoints"):
        assert (tmp_path / f"{name}.{fmt}").read_bytes() == b"the export before"


def test_a_plan_without_parts_exports_its_columns(runner, stored, tmp_path):
    url = stored[0]
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body={**BODY, "name": "no-parts-yet"}).body["id"]
    engine.dispose()
    assert _export(runner, url, plan_id, tmp_path / "csv", "csv").exit_code == 0
    header = (tmp_path / "csv" / "decisions.csv").read_bytes()
    assert header == b",".join(c.encode() for c in tidy.COLUMNS["decisions"]) + b"\r\n"
    assert len(pd.read_csv(tmp_path / "csv" / "setpoints.csv")) == 6  # version 1
    assert _export(runner, url, plan_id, tmp_path / "pq", "parquet").exit_code == 0
    measurements = pq.ParquetFile(tmp_path / "pq" / "measurements.parquet")
    assert measurements.metadata.num_rows == 0
    assert measurements.schema_arrow.names == list(tidy.COLUMNS["measurements"])
    assert str(measurements.schema_arrow.field("value").type) == "double"
