"""Where the benchmark finds the project, and the figures it aims at."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PLAN_FILE = ROOT / "examples" / "ivester_demo_part.toml"
RCB = Path(sys.executable).with_name("rcb")
PREFIX = "/api/v1"
#: Table 5's measured +- columns, as in tests/conftest.py (TABLE5_UNCERTAINTY).
UNCERTAINTY = {"force_N": 3.0, "roughness_um": 0.05}
DEFAULT_POSTGRES = (
    os.environ.get("RCB_TEST_POSTGRES_URL") or "postgresql+psycopg://postgres@127.0.0.1:5432/test"
)
#: The issue's targets (PostgreSQL).
TARGET_P50_MS = 20.0
TARGET_RPS = 200.0
CLK_TCK = os.sysconf("SC_CLK_TCK")

perf = time.perf_counter
