"""Shared fixtures: the example plan and a CLI runner."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parent.parent
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()
