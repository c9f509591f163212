"""Shared fixtures: the example plan and a CLI runner."""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import text
from sqlalchemy.engine import make_url
from typer.testing import CliRunner

from db.engine import make_engine, upgrade

from live import LiveServer

ROOT = Path(__file__).resolve().parent.parent
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"
POSTGRES = os.environ.get("RCB_TEST_POSTGRES_URL")
#: Ivester & Heigel Table 5's measured ± columns (force_N, roughness_um).
TABLE5_UNCERTAINTY = {"force_N": 3.0, "roughness_um": 0.05}


def report_at(
    serial: str, setpoints: dict[str, Any], uncertainty: dict[str, float] = TABLE5_UNCERTAINTY
) -> dict[str, Any]:
    """A part report made with ``setpoints`` (an answer's ``setpoint_version`` and
    ``operations``): each quantity of ``uncertainty`` measured at its prediction."""
    return {
        "serial": serial,
        "setpoint_version": setpoints["setpoint_version"],
        "operations": [
            {
                "name": op["name"],
                "measurements": {
                    q: {"value": op["predicted"][q]["value"], "uncertainty": u}
                    for q, u in uncertainty.items()
                },
            }
            for op in setpoints["operations"]
        ],
    }


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture
def empty_postgres() -> Iterator[str]:
    yield from _fresh_postgres()


@pytest.fixture(scope="module")
def module_postgres() -> Iterator[str]:
    yield from _fresh_postgres()


def _fresh_postgres() -> Iterator[str]:
    """A new, empty PostgreSQL database, dropped afterwards."""
    if not POSTGRES:
        pytest.skip("RCB_TEST_POSTGRES_URL not set: no PostgreSQL to test against")
    name = f"rcb_test_{uuid.uuid4().hex[:12]}"
    admin = make_engine(POSTGRES).execution_options(isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{name}"'))
    try:
        yield make_url(POSTGRES).set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@pytest.fixture(params=["sqlite", "postgres"])
def backend_url(request, tmp_path) -> str:
    """An empty database: a SQLite file, or a fresh PostgreSQL database."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'rcb.db'}"
    return request.getfixturevalue("empty_postgres")


@pytest.fixture
def engine(backend_url):
    """A migrated database on each backend, as an engine."""
    upgrade(backend_url)
    engine = make_engine(backend_url)
    yield engine
    engine.dispose()


@pytest.fixture(scope="module", params=["sqlite", "postgres"])
def server(request, tmp_path_factory) -> Iterator[LiveServer]:
    """A running ``rcb serve`` on a fresh database, shared by a module's tests."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path_factory.mktemp('db') / 'rcb.db'}"
    else:
        url = request.getfixturevalue("module_postgres")
    live = LiveServer(url, tmp_path_factory.mktemp("log") / "serve.log")
    live.start()
    yield live
    live.stop()
