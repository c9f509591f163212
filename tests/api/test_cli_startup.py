"""``rcb --help`` imports none of the heavy libraries; a command still imports what it uses.

Issue 18 item 8: every command module used to import cvxpy, SciPy, pandas, SQLAlchemy,
matplotlib and uvicorn at the top, so ``rcb --help`` took about 2 s and 250 MB. The commands now
import them where they run (README, "Speed"; the figures come from ``benchmarks/cli_startup.py``,
never from a timed test). These tests count loaded modules instead of seconds: on the old code
``rcb --help`` loads every library of :data:`LAZY`.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib

import pytest

from api.services.plans import create_plan
from db.engine import make_engine

from conftest import DEMO_PLAN, ROOT
from migrated import migrated

#: What ``rcb --help`` must not load: the solvers, the numerics, the database and web stacks.
LAZY = (
    "cvxpy",
    "scipy",
    "numpy",
    "pandas",
    "pyarrow",
    "matplotlib",
    "sqlalchemy",
    "alembic",
    "fastapi",
    "uvicorn",
    "highspy",
    "clarabel",
)

#: Runs ``rcb ARGS`` in a fresh interpreter; prints its exit code and which of LAZY it loaded.
_PROBE = """
import json, sys
lazy, args = json.loads(sys.argv[1]), sys.argv[2:]
from api.cli.main import app
try:
    app(args, prog_name="rcb")
    code = 0
except SystemExit as done:
    code = done.code
loaded = sorted({m.split(".")[0] for m in sys.modules} & set(lazy))
print(json.dumps({"code": code, "loaded": loaded}), file=sys.stderr)
"""


def _probe(*args: str) -> tuple[int, list[str], str]:
    """Exit code, the libraries of :data:`LAZY` loaded, and stdout of ``rcb ARGS``."""
    proc = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(LAZY), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    found = json.loads(proc.stderr.strip().splitlines()[-1])
    return found["code"], found["loaded"], proc.stdout


@pytest.mark.parametrize("args", [["--help"], [], ["demo", "--help"], ["plans", "--help"]])
def test_help_loads_no_heavy_library(args):
    code, loaded, out = _probe(*args)
    assert code in (0, 2)  # without arguments: the help, with click's usage exit code
    assert "Commands" in out or "Options" in out
    assert loaded == []


def test_a_lazy_group_imports_its_commands():
    # rcb milling's options need NumPy-backed values (Tai's safety factor, the controllers)
    code, loaded, out = _probe("milling", "--help")
    assert code == 0
    assert [name for name in ("domain", "control", "setup") if name in out] == [
        "domain",
        "control",
        "setup",
    ]
    assert "numpy" in loaded


def test_demo_still_imports_what_it_uses(tmp_path):
    db = f"sqlite:///{tmp_path / 'demo.db'}"
    code, loaded, out = _probe("demo", "--parts", "2", "--json", "--db", db)
    assert code == 0
    assert json.loads(out)["parts"] == 2
    assert {"numpy", "highspy", "sqlalchemy"} <= set(loaded)  # it stores (api.services.demo)


@pytest.fixture(scope="module")
def one_plan(tmp_path_factory) -> str:
    """A migrated SQLite database holding the demonstration plan (id 1), as a URL."""
    url = f"sqlite:///{tmp_path_factory.mktemp('startup') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    create_plan(engine=engine, body=tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8")))
    engine.dispose()
    return url


@pytest.mark.parametrize(
    "args",
    [
        ["plans"],
        ["history", "1"],
        ["history", "ivester-demo-part"],
        ["parts", "1"],
        ["fleet", "law", "CNMG432RN"],
    ],
    ids=["plans", "history", "history-by-name", "parts", "fleet-law"],
)
def test_a_reader_of_the_database_loads_no_scipy_and_no_solver(one_plan, args):
    """The readers of a plan never solve. SciPy (0.2-0.5 s) came in through the fleet's noise
    prior and the cone solver's sparse matrices, both now imported where they are used; the
    solvers through the plan services' module, where a PLAN name was resolved (now a reader's:
    ``api/services/read/common.py``). docs/benchmarks.md, "Start-up of rcb"."""
    code, loaded, _ = _probe(*args, "--db", one_plan)
    assert code == 0
    assert {"sqlalchemy", "numpy"} <= set(loaded)
    heavy = {"scipy", "cvxpy", "highspy", "clarabel", "pandas", "matplotlib", "fastapi"}
    assert heavy.isdisjoint(loaded), loaded
    # the database's revision is checked against db.engine.HEAD_REVISION (Alembic: 0.12 s)
    assert "alembic" not in loaded
