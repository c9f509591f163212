"""Shared fixtures: the example plan and a CLI runner."""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from sqlalchemy import text
from sqlalchemy.engine import make_url
from typer.testing import CliRunner

from db.engine import make_engine

ROOT = Path(__file__).resolve().parent.parent
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"
POSTGRES = os.environ.get("RCB_TEST_POSTGRES_URL")


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture
def empty_postgres() -> Iterator[str]:
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
