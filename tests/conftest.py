"""Shared fixtures: the example plan, a CLI runner, the databases and a live server.

PostgreSQL: ``RCB_TEST_POSTGRES_URL`` when set (empty: PostgreSQL tests off); otherwise a
server answering on 127.0.0.1:5432 with a ``test`` database (user ``postgres``), probed once
per session with a short timeout; otherwise those tests skip, saying how to enable them.
"""

from __future__ import annotations

import copy
import functools
import itertools
import os
import socket
import tomllib
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import psycopg
import pytest
from sqlalchemy import Engine, text
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session
from typer.testing import CliRunner

from db.engine import make_engine
from db.plans import get_plan_row
from db.state import load_state
from db.state_cache import CACHE, database_key
from supervisor.inputs.resolution import DEFAULT_RESOLUTION
from supervisor.rcb.state import RcbState

from live import LiveServer
from migrated import admin_engine, migrated

if TYPE_CHECKING:
    from scale_support import Copied, PostgresCopied

#: Bytecode compiled once and each typer app's click command built once: tests/suite_speed.py.
pytest_plugins = ["suite_speed"]

ROOT = Path(__file__).resolve().parent.parent
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"
#: The variable naming the PostgreSQL server the tests create their databases on.
POSTGRES_VARIABLE = "RCB_TEST_POSTGRES_URL"
#: The server the suite finds by itself when the variable is not set.
LOCAL_POSTGRES = "postgresql+psycopg://postgres@127.0.0.1:5432/test"
#: Seconds to wait for the local server (it is on this host: it answers at once or not at all).
PROBE_TIMEOUT_S = 0.5
#: Ivester & Heigel Table 5's measured ± columns (force_N, roughness_um).
TABLE5_UNCERTAINTY = {"force_N": 3.0, "roughness_um": 0.05}
#: A resolution so fine that the setpoint is the continuous optimum to about 1e-8: tests of a
#: hand-solved optimum use it; tests/supervisor/test_setpoint_resolution.py and
#: test_setpoint_grid_rule.py check the grid itself.
FINE = dict.fromkeys(DEFAULT_RESOLUTION, 1e-9)


def step1_plan(resolution: dict[str, float] | None = None) -> dict[str, Any]:
    """Ivester & Heigel Table 5 step 1 (the demonstration part's rough OD, Table 4) as a plan
    mapping, a new one per call; ``resolution``: the machine's (None: the defaults)."""
    machine: dict[str, Any] = {"name": "lathe-22kW", "max_power_kW": 22, "max_spindle_rpm": 4000}
    if resolution is not None:
        machine["resolution"] = dict(resolution)
    return {
        "name": "step1",
        "machine": machine,
        "operations": [
            {
                "name": "rough-od",
                "tool": "CNMG432RN",
                "workpiece_diameter_mm": 60,
                "volume_mm3": 86400,
                "limits": {"force_N": 2000, "roughness_um": 4.0},
                "bounds": {
                    "depth_mm": [0.5, 3.0],
                    "feed_mm_rev": [0.1, 0.6],
                    "speed_m_min": [100, 200],
                },
            }
        ],
    }


def stored_state(engine: Engine, plan_id: int) -> RcbState:
    """A plan's RCB state as the database holds it (the in-process cache forgotten first)."""
    CACHE.clear()
    with Session(engine) as session, session.begin():
        row = get_plan_row(session=session, plan_id=plan_id, lock=True)
        return load_state(session=session, plan_row=row)


def cached_state(engine: Engine, plan_id: int) -> RcbState:
    """The state the last report left in this process (db.state_cache), not read back."""
    with Session(engine) as session:
        row = get_plan_row(session=session, plan_id=plan_id)
        state = CACHE.get(database_key(session), plan_id, row.state_token)
    assert state is not None
    return state


def demo_body() -> dict[str, Any]:
    """The demonstration plan file as a REST body, a fresh copy a test may change."""
    return copy.deepcopy(_demo_body())


@functools.cache
def _demo_body() -> dict[str, Any]:
    return tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def report_at(
    serial: str,
    setpoints: dict[str, Any],
    uncertainty: dict[str, float] = TABLE5_UNCERTAINTY,
    fraction: float = 1.0,
) -> dict[str, Any]:
    """A part report made with ``setpoints`` (an answer's ``setpoint_version`` and
    ``operations``): each quantity of ``uncertainty`` measured at ``fraction`` of its
    prediction."""
    return {
        "serial": serial,
        "setpoint_version": setpoints["setpoint_version"],
        "operations": [
            {
                "name": op["name"],
                "measurements": {
                    q: {"value": op["predicted"][q]["value"] * fraction, "uncertainty": u}
                    for q, u in uncertainty.items()
                },
            }
            for op in setpoints["operations"]
        ],
    }


#: What differs between two databases (or two plans) holding the same history: ids and times.
UNSHARED = frozenset({"created_at", "received_at", "part_id", "plan_id"})


def without_ids(data: Any) -> Any:
    """``data`` (JSON) without :data:`UNSHARED` keys, at any depth."""
    if isinstance(data, dict):
        return {k: without_ids(v) for k, v in data.items() if k not in UNSHARED}
    if isinstance(data, list):
        return [without_ids(v) for v in data]
    return data


#: Numbers the plans :func:`renamed` makes (one count per test process).
_PLAN_NAMES = itertools.count(1)


def renamed(body: dict[str, Any]) -> dict[str, Any]:
    """``body`` under a name of its own: a name names one plan (alembic 0011), and a module's
    server or a test may store several plans of one plan file."""
    return {**body, "name": f"{body['name']}-{next(_PLAN_NAMES)}"}


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def engine_url(engine: Engine) -> str:
    """The URL of ``engine``'s database, its password shown (as ``--db`` takes it)."""
    return engine.url.render_as_string(hide_password=False)


def invoke(runner: CliRunner, *args: str) -> Any:
    """``rcb ARGS`` in process; whatever its exit code, never a traceback."""
    from api.cli.main import app

    done = runner.invoke(app, list(args))
    assert "Traceback" not in done.output + done.stderr
    return done


@pytest.fixture
def empty_postgres() -> Iterator[str]:
    yield from _fresh_postgres()


@pytest.fixture(scope="module")
def module_postgres() -> Iterator[str]:
    yield from _fresh_postgres()


@functools.cache
def postgres_url() -> str | None:
    """The PostgreSQL URL the tests use, or None: the variable, else the local server if it
    answers (probed once per session), else None."""
    if POSTGRES_VARIABLE in os.environ:
        return os.environ[POSTGRES_VARIABLE] or None
    return LOCAL_POSTGRES if _local_postgres_answers() else None


def _local_postgres_answers() -> bool:
    """Whether :data:`LOCAL_POSTGRES` accepts a connection to its ``test`` database."""
    url = make_url(LOCAL_POSTGRES)
    try:
        with socket.create_connection((url.host, url.port), timeout=PROBE_TIMEOUT_S):
            pass
        with psycopg.connect(
            host=url.host, port=url.port, user=url.username, dbname=url.database, connect_timeout=2
        ):
            return True
    except (OSError, psycopg.Error):
        return False


def postgres_skip_reason() -> str:
    """Why the PostgreSQL tests skip, and how to enable them."""
    if os.environ.get(POSTGRES_VARIABLE) == "":
        return f"{POSTGRES_VARIABLE} is empty: PostgreSQL tests off"
    return (
        f"no PostgreSQL: none answers on 127.0.0.1:5432 with a 'test' database (user postgres), "
        f"and {POSTGRES_VARIABLE} is not set; set it to enable these tests, e.g. "
        f"{POSTGRES_VARIABLE}=postgresql+psycopg://USER[:PASSWORD]@HOST:PORT/DATABASE "
        "(the user may create databases)"
    )


def _fresh_postgres() -> Iterator[str]:
    """A new, empty PostgreSQL database, dropped afterwards."""
    server = postgres_url()
    if server is None:
        pytest.skip(postgres_skip_reason())
    name = f"rcb_test_{uuid.uuid4().hex[:12]}"
    admin = admin_engine(server)
    with admin.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{name}"'))
    try:
        yield make_url(server).set(database=name).render_as_string(hide_password=False)
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
    migrated(backend_url)
    engine = make_engine(backend_url)
    yield engine
    engine.dispose()


@pytest.fixture
def sqlite_engine(tmp_path) -> Iterator[Engine]:
    """A migrated SQLite database, as an engine (for SQLite's own query plans and hooks)."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    made = make_engine(url)
    yield made
    made.dispose()


def _serving(url: str, tmp_path_factory) -> Iterator[LiveServer]:
    live = LiveServer(url, tmp_path_factory.mktemp("log") / "serve.log")
    live.start()
    yield live
    live.stop()


@pytest.fixture(scope="module", params=["sqlite", "postgres"])
def server(request, tmp_path_factory) -> Iterator[LiveServer]:
    """A running ``rcb serve`` on a fresh database, shared by a module's tests."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path_factory.mktemp('db') / 'rcb.db'}"
    else:
        url = request.getfixturevalue("module_postgres")
    yield from _serving(url, tmp_path_factory)


@pytest.fixture(scope="module")
def plan(server, request) -> dict[str, Any]:
    """The demonstration plan created once on the module's :func:`server`: the answer to its
    ``POST /plans`` (id and first setpoints). Named after the module: ``test_rest_identities``
    makes ``identities``, ``test_content_type`` ``content-type``. A module may define its own."""
    name = request.module.__name__.removeprefix("test_").removeprefix("rest_")
    with server.client("engineer") as c:
        r = c.post("/plans", json={**demo_body(), "name": name.replace("_", "-")})
        assert r.status_code == 201, r.text
        return r.json()


@pytest.fixture(scope="module")
def sqlite_server(tmp_path_factory) -> Iterator[LiveServer]:
    """A running ``rcb serve`` on a fresh SQLite database, shared by a module's tests."""
    yield from _serving(f"sqlite:///{tmp_path_factory.mktemp('db') / 'rcb.db'}", tmp_path_factory)


@pytest.fixture(params=["sqlite", "postgres"])
def bayes_history(request, tmp_path, tmp_path_factory) -> Iterator[Copied | PostgresCopied]:
    """test_service.BODY under the bayes strategy (a setpoint version per part) after n of its
    virtual-lathe reports, ``.at(n)`` an engine on a database of the test's own, copied from
    the run's shared one (tests/scale_support.py): a SQLite file, or a PostgreSQL database."""
    from scale_support import Copied, PostgresCopied  # it imports test_service, which imports this

    history: Copied | PostgresCopied
    if request.param == "sqlite":
        history = Copied(tmp_path_factory, tmp_path, "bayes")
    else:
        server = postgres_url()
        if server is None:
            pytest.skip(postgres_skip_reason())
        history = PostgresCopied(tmp_path_factory, server)
    yield history
    history.close()


def pytest_sessionfinish(session: pytest.Session) -> None:
    """The run's shared PostgreSQL histories dropped, once every worker is done (the xdist
    controller, or the only process): tests/scale_support.py."""
    if hasattr(session.config, "workerinput") or (server := postgres_url()) is None:
        return
    from scale_support import drop_postgres_snapshots

    drop_postgres_snapshots(session.config._tmp_path_factory.getbasetemp(), server)


#: The files that take longest, run first and longest first: the sum of their tests' times
#: (setup and teardown included) in a full run on a 2-core host at load 7-13 (issue 30 item
#: 8); every other file took under 20 s. ``--dist loadfile`` hands each worker whole files in
#: collection order (``--no-loadscope-reorder``: not xdist's order by number of tests, which
#: put files of few long tests last): the long files run beside each other and the short ones
#: fill in after them. test_list_paging's time includes building the run's shared bayes
#: histories (tests/scale_support.py) that the scale files after it copy.
HEAVY_FIRST = (
    "api/test_rest_concurrency.py",  # 128 s
    "api/test_cli_width.py",  # 120 s
    "api/test_rest_schema.py",  # 107 s
    "api/test_list_paging.py",  # 100 s
    "api/test_docs.py",  # 87 s
    "db/test_cli_db_errors.py",  # 82 s
    "api/test_cli_actor.py",  # 76 s
    "api/test_note_surfaces.py",  # 72 s
    "api/test_collect_opcua_nodesets.py",  # 63 s
    "api/test_virtual_serve.py",  # 41 s
    "api/test_rest_pool.py",  # 41 s
    "api/test_history_scale.py",  # 40 s
    "api/test_collect_opcua.py",  # 39 s
    "api/test_content_type.py",  # 37 s
    "db/test_migration_lock.py",  # 36 s
    "api/test_report_scale.py",  # 32 s
    "api/test_shop_floor_rest.py",  # 31 s
    "api/test_shop_floor_rest_breach.py",  # split from test_shop_floor_rest (31 s together)
    "api/test_rest_sweep.py",  # 29 s
    "api/test_rest_identities.py",  # 27 s
    "api/test_cli_errors.py",  # 27 s with the two below, split from it
    "api/test_cli_errors_predict.py",
    "api/test_cli_errors_unsolvable.py",
    "supervisor/test_gcode_stream.py",  # 24 s
    "api/test_keys_scope_audit.py",  # 23 s
    "api/test_rest_validation.py",  # 23 s
    "api/test_collect_mtconnect.py",  # 23 s
    "api/test_plan_names.py",  # 22 s
    "api/test_replan.py",  # 22 s
    "supervisor/test_cam_acceptance.py",  # 22 s
    "supervisor/test_cam_bombs.py",  # 22 s
    "api/test_audit_burst.py",  # 21 s
    "api/test_examples.py",  # 20 s
)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files of :data:`HEAVY_FIRST` (paths under tests/) first, in its order, then the rest in
    collection order (folder, then name); the order within a file (and its module fixtures'
    grouping) is kept: the sort is stable."""
    rank = {name: i for i, name in enumerate(HEAVY_FIRST)}
    tests = Path(__file__).resolve().parent

    def key(item: pytest.Item) -> int:
        path = item.path.resolve()
        return (
            rank.get(path.relative_to(tests).as_posix(), len(rank))
            if path.is_relative_to(tests)
            else len(rank)
        )

    items.sort(key=key)
