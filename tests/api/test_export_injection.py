"""rcb export: no CSV cell a spreadsheet would run as a formula (issue 29, OWASP CSV injection).

Hostile serials are stored through the service the MES's reports go through (as
tests/api/test_review.py stores its parts); a tab and a carriage return, which every reader now
refuses in a serial, are written into two stored rows as a database from before that check holds
them. Every file is read back: each such text cell carries the single quote, numbers stay numbers,
and the parquet files keep what is stored.
"""

from __future__ import annotations

import pandas as pd
import pytest
from sqlalchemy import update
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli.main import app
from api.report.export import FORMULA_STARTS, neutralised
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine

from migrated import migrated

#: Serials a spreadsheet would run: OWASP's examples and one per starting character.
HOSTILE = [
    '=HYPERLINK("http://evil/","x")',
    "@SUM(1+1)*cmd|' /C calc'!A0",
    "+1+cmd|' /C calc'!A0",
    "-2+3+cmd|' /C calc'!A0",
]
#: Written into stored rows (the REST schema and the report reader refuse control characters).
STORED_RAW = ["\tTAB=1+1", "\rCR=1+1"]
FILES = ("parts", "measurements", "decisions", "setpoints")


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    root = tmp_path_factory.mktemp("inject")
    url = f"sqlite:///{root / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    bodies, _ = _reports(len(HOSTILE) + len(STORED_RAW))
    serials = [*HOSTILE, *(f"SN-RAW-{i}" for i in range(len(STORED_RAW)))]
    for body, serial in zip(bodies, serials, strict=True):
        body["serial"] = serial
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    with Session(engine) as session, session.begin():
        for i, raw in enumerate(STORED_RAW):
            session.execute(update(t.Part).where(t.Part.serial == f"SN-RAW-{i}").values(serial=raw))
    engine.dispose()
    return url, plan_id, root


def _number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _export(runner, url, plan_id, out, fmt):
    args = ["export", str(plan_id), "--format", fmt, "--out", str(out), "--db", url]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output


def test_every_formula_cell_is_neutralised_in_every_csv(runner, exported):
    url, plan_id, root = exported
    out = root / "csv"
    _export(runner, url, plan_id, out, "csv")
    stored = [*HOSTILE, *STORED_RAW]
    for name in FILES:
        text = pd.read_csv(out / f"{name}.csv", dtype=str, keep_default_na=False)
        cells = [c for column in text for c in text[column]]
        assert cells, name
        assert not [c for c in cells if c.startswith(FORMULA_STARTS) and not _number(c)], name
        if name == "setpoints":  # its serial is that of the part that caused the version
            continue
        assert set(stored) & set(text.serial) == set(), name
        assert {"'" + s for s in stored} <= set(text.serial), name
    typed = pd.read_csv(out / "decisions.csv")
    assert typed.margin.dtype == float and (typed.margin < 0).any()  # a negative number stays one
    setpoints = pd.read_csv(out / "setpoints.csv")
    caused = {s for s in setpoints.serial.dropna() if s}
    assert caused and caused <= {"'" + s for s in stored}
    assert setpoints.depth_mm.dtype == float


def test_parquet_keeps_what_is_stored(runner, exported):
    url, plan_id, root = exported
    out = root / "parquet"
    _export(runner, url, plan_id, out, "parquet")
    parts = pd.read_parquet(out / "parts.parquet")
    assert sorted(parts.serial) == sorted([*HOSTILE, *STORED_RAW])


@pytest.mark.parametrize(
    ("cell", "safe"),
    [
        ("=1+1", "'=1+1"),
        ("+1", "'+1"),
        ("-1", "'-1"),
        ("@A1", "'@A1"),
        ("\tx", "'\tx"),
        ("\rx", "'\rx"),
        ("SN-=1", "SN-=1"),
        ("", ""),
        (-1.5, -1.5),
        (None, None),
    ],
)
def test_neutralised_prefixes_text_only(cell, safe):
    assert neutralised(cell) == safe
