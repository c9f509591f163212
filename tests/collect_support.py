"""What the collector tests share: the demo plan with a spindle-load calibration, its trace, the
part reports an MES would post for the same parts, and ``rcb collect`` as a real process."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import time
import tomllib
from pathlib import Path
from typing import Any

import httpx

from supervisor.inputs.plan import plan_from_mapping
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.trace import TracedOperation, TraceSample, machine_trace, traced_operations

from conftest import DEMO_PLAN, renamed, without_ids
from live import RCB, LiveServer, kill_group, stop_group

MACHINE, PROGRAM = "lathe-1", "O1001"
UNCERTAINTY_V = 0.02  # expanded (k = 2) uncertainty of one spindle-load reading
KEY_VARIABLE = "RCB_TEST_COLLECT_KEY"
#: The demonstration part with the NIST lathe's spindle-load calibration (Ivester & Heigel
#: Eqs. 1-4, the paper's constants) and an idle-load table over the demo's speeds.
CALIBRATION = {
    "kind": "ivester_spindle_load",
    "source": "test: Ivester & Heigel constants, idle table chosen",
    "idle_speeds_rpm": [300, 1200, 2400],
    "idle_loads_V": [0.20, 0.35, 0.55],
    "u_idle_load_V": 0.01,
}


def plan_body() -> dict[str, Any]:
    body = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    body["machine"]["calibrations"] = {"spindle_load": dict(CALIBRATION)}
    return body


def new_plan(live: LiveServer) -> tuple[int, dict[str, dict[str, float]]]:
    """A plan on the service and its version-1 setpoints by operation."""
    with live.client("engineer") as c:
        created = c.post("/plans", json=renamed(plan_body()), params={"strategy": "ivester"})
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        answer = c.get(f"/plans/{plan_id}/setpoints").json()
    return plan_id, {op["name"]: op["setpoint"] for op in answer["operations"]}


def demo_trace(
    setpoints: dict[str, dict[str, float]], parts: int, seed: int = 7
) -> tuple[tuple[TracedOperation, ...], list[TraceSample]]:
    plan = plan_from_mapping(plan_body())
    machine = sample_machine(plan, seed)
    ops = traced_operations(
        plan, setpoints, machine, plan.machine.calibrations["spindle_load"], seed
    )
    return ops, machine_trace(ops, parts, seed)


def mes_reports(ops: tuple[TracedOperation, ...], trace: list[TraceSample]) -> list[dict[str, Any]]:
    """The report of every part as an MES would post it, read off the trace itself."""
    parts = max(s.part_count for s in trace)
    reports = []
    for count in range(1, parts + 1):
        operations = []
        for op in ops:
            loads = [
                s.spindle_load
                for s in trace
                if s.part_count == count - 1 and s.execution == "ACTIVE" and s.block in op.blocks
            ]
            reading = {
                "value": max(loads),
                "uncertainty": UNCERTAINTY_V,
                "calibration": "spindle_load",
                "spindle_speed_rpm": op.spindle_speed_rpm,
                "feed_rate_mm_min": op.feed_rate_mm_min,
            }
            operations.append({"name": op.name, "measurements": {"spindle_load_V": reading}})
        serial = f"{MACHINE}/{PROGRAM}/{count}"
        reports.append({"serial": serial, "setpoint_version": 1, "operations": operations})
    return reports


def post_directly(live: LiveServer, plan_id: int, reports: list[dict[str, Any]]) -> None:
    with live.client("mes") as c:
        for body in reports:
            answer = c.post(
                f"/plans/{plan_id}/parts",
                json=body,
                headers={"Idempotency-Key": f"mes:{plan_id}:{body['serial']}"},
            )
            assert answer.status_code == 201, answer.text


def outcome(live: LiveServer, plan_id: int) -> dict[str, Any]:
    """Every part (serial, version, measurements, band updates), setpoint version and model."""
    with live.client("viewer") as c:
        parts = c.get(f"/plans/{plan_id}/parts", params={"limit": 500}).json()["items"]
        history = c.get(f"/plans/{plan_id}/history", params={"limit": 500}).json()["versions"]
        models = c.get(f"/plans/{plan_id}/models").json()["operations"]
    return without_ids({"parts": parts, "versions": history, "models": models})


def write_config(
    folder: Path, service: str, plan_id: int, selectors: list[str], source: str
) -> Path:
    path = folder / "collector.toml"
    lines = [
        "[collector]",
        f'machine = "{MACHINE}"',
        'queue = "queue.sqlite"',
        "retry_max_s = 0.5",
        "[service]",
        f'url = "{service}"',
        f"plan = {plan_id}",
        "setpoint_version = 1",
        f'api_key_env = "{KEY_VARIABLE}"',
        "[signal]",
        'quantity = "spindle_load_V"',
        f"uncertainty = {UNCERTAINTY_V}",
        'calibration = "spindle_load"',
        "operations = [" + ", ".join(f'"{s}"' for s in selectors) + "]",
        source,
    ]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


class Collector:
    """``rcb collect --config FILE`` in its own process group."""

    def __init__(self, config: Path, key: str) -> None:
        self.config, self.key = config, key
        self.log = config.parent / "collector.log"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self, ready: bool = True) -> None:
        """Start it; with ``ready`` wait until it has read the agent (its checkpoint exists)."""
        env = {**os.environ, KEY_VARIABLE: self.key}
        with self.log.open("ab") as log:
            self.process = subprocess.Popen(
                [str(RCB), "collect", "--config", str(self.config)],
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
            )
        if ready:
            self.wait(lambda c: c.get("ready", 0) == 1, what="the collector to start")

    def kill(self) -> None:
        assert self.process is not None
        kill_group(self.process)
        self.process = None

    def stop(self) -> None:
        if self.process is not None:
            stop_group(self.process)
            self.process = None

    def wait_log(self, text: str, times: int, timeout_s: float = 60.0) -> None:
        """Wait until ``text`` is in the collector's log ``times`` times."""
        deadline = time.monotonic() + timeout_s
        while self.log.read_text().count(text) < times:
            assert time.monotonic() < deadline, self.log.read_text()[-2000:]
            time.sleep(0.05)

    def counts(self) -> dict[str, int]:
        """Reports by state, parts skipped and gaps, read from the queue file."""
        path = self.config.parent / "queue.sqlite"
        if not path.exists():
            return {}
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=10)
        try:
            states = dict(db.execute("SELECT state, count(*) FROM reports GROUP BY state"))
            states["gaps"] = db.execute("SELECT count(*) FROM gaps").fetchone()[0]
            states["skips"] = db.execute("SELECT count(*) FROM skipped").fetchone()[0]
            states["ready"] = db.execute("SELECT count(*) FROM checkpoint").fetchone()[0]
        except sqlite3.OperationalError:
            return {}
        finally:
            db.close()
        return states

    def wait(self, condition: Any, timeout_s: float = 60.0, what: str = "") -> dict[str, int]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process is not None and self.process.poll() is not None:
                raise AssertionError(f"rcb collect exited: {self.log.read_text()[-3000:]}")
            counts = self.counts()
            if condition(counts):
                return counts
            time.sleep(0.02)
        raise AssertionError(
            f"timed out waiting for {what}: {self.counts()}\n{self.log.read_text()[-3000:]}"
        )


def service_parts(live: LiveServer, plan_id: int) -> list[str]:
    with httpx.Client(base_url=live.base, timeout=30) as c:
        c.headers["Authorization"] = f"Bearer {live.keys['viewer']}"
        items = c.get(f"/plans/{plan_id}/parts", params={"limit": 500}).json()["items"]
    return [p["serial"] for p in items]


def refused(folder: Path, source: str) -> tuple[list[str], str]:
    """``rcb collect`` with ``source`` appended to a config: exit 2, no traceback.

    Returns its ``rcb: error:`` lines and its whole stderr.
    """
    config = write_config(folder, "http://127.0.0.1:9/api/v1", 1, ["a=N100:N140"], "")
    config.write_text(config.read_text(encoding="utf-8") + source + "\n", encoding="utf-8")
    answer = subprocess.run(
        [str(RCB), "collect", "--config", str(config)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, KEY_VARIABLE: "not-used"},
    )
    assert answer.returncode == 2, answer.stderr[-2000:]
    assert "Traceback" not in answer.stderr and "ValueError" not in answer.stderr
    return [x for x in answer.stderr.splitlines() if x.startswith("rcb: error:")], answer.stderr
