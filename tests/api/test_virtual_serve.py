"""``rcb virtual serve`` as a real process, read by a real ``rcb collect`` posting to ``rcb serve``.

Over each protocol: the virtual lathe waits for the collector, makes its parts, the collector
stores every one (the values it sends are the ones the machine made), the plan's setpoints
improve, and both stop cleanly on SIGTERM, saying so. A collector started after the parts were
made says it waits for new parts (and sends none); with ``start = "buffer"`` it reads them.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import time
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from api.services.plans import create_plan
from db.engine import make_engine

from collect_support import refused
from conftest import DEMO_PLAN, ROOT, renamed
from live import RCB, LiveServer, free_port, stop_group
from migrated import migrated

PLAN = ROOT / "examples" / "virtual_lathe_part.toml"
TIMEOUT_S = 120.0


class Process:
    """An ``rcb`` command in its own process group, its output in a log file."""

    def __init__(self, args: list[str], log: Path, env: dict[str, str] | None = None) -> None:
        self.log = log
        with log.open("ab") as out:
            self.process = subprocess.Popen(
                [str(RCB), *args],
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, **(env or {})},
                start_new_session=True,
            )

    def text(self) -> str:
        return self.log.read_text(encoding="utf-8")

    def wait_log(self, pattern: str, timeout_s: float = TIMEOUT_S) -> re.Match[str]:
        """Wait until ``pattern`` (a regular expression) is in the log; its match."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            found = re.search(pattern, self.text())
            if found:
                return found
            if self.process.poll() is not None:
                raise AssertionError(f"exited {self.process.returncode}: {self.text()[-3000:]}")
            time.sleep(0.05)
        raise AssertionError(f"no {pattern!r} in {timeout_s} s: {self.text()[-3000:]}")

    def terminate(self) -> int:
        """SIGTERM, and the exit code (within 30 s)."""
        os.killpg(self.process.pid, signal.SIGTERM)
        return self.process.wait(timeout=30)

    def kill(self) -> None:
        if self.process.poll() is None:
            stop_group(self.process)


def new_plan(live: LiveServer) -> int:
    body = renamed(tomllib.loads(PLAN.read_text(encoding="utf-8")))
    with live.client("engineer") as c:
        created = c.post("/plans", json=body, params={"strategy": "ivester"})
    assert created.status_code == 201, created.text
    return int(created.json()["id"])


def stored(live: LiveServer, plan_id: int) -> list[str]:
    with live.client("viewer") as c:
        items = c.get(f"/plans/{plan_id}/parts", params={"limit": 500}).json()["items"]
    return [p["serial"] for p in items]


def wait_stored(live: LiveServer, plan_id: int, n: int, collector: Process) -> list[str]:
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:
        serials = stored(live, plan_id)
        if len(serials) >= n:
            return serials
        assert collector.process.poll() is None, collector.text()[-3000:]
        time.sleep(0.1)
    raise AssertionError(f"{stored(live, plan_id)} after {TIMEOUT_S} s: {collector.text()[-3000:]}")


def versions(live: LiveServer, plan_id: int) -> list[dict[str, object]]:
    with live.client("viewer") as c:
        answer = c.get(f"/plans/{plan_id}/history", params={"limit": 500})
    assert answer.status_code == 200, answer.text
    return list(answer.json()["versions"])


def virtual(tmp: Path, protocol: str, live: LiveServer, plan_id: int, *extra: str) -> Process:
    args = ["virtual", "serve", "--protocol", protocol, "--plan", str(PLAN)]
    args += ["--port", str(free_port()), "--collector", str(tmp / "collector.toml")]
    args += ["--service-url", live.base, "--plan-id", str(plan_id), *extra]
    machine = Process(args, tmp / "virtual.log")
    machine.wait_log(r"rcb virtual: wrote ")
    return machine


def collect(tmp: Path, live: LiveServer, *extra: str) -> Process:
    env = {"RCB_API_KEY": live.keys["mes"]}
    args = ["collect", "--config", str(tmp / "collector.toml"), *extra]
    return Process(args, tmp / "collect.log", env)


def peaks(text: str, pattern: str) -> dict[int, str]:
    """The loads logged for each part: part number → ``rough-od 1.358 V, ...``."""
    return {int(m[1]): re.sub(r" \(\d+ samples\)", "", m[2]) for m in re.finditer(pattern, text)}


@pytest.mark.parametrize("protocol", ["mtconnect", "opcua"])
def test_serve_collect_and_the_setpoints_improve(sqlite_server, tmp_path, protocol):
    parts = 6
    plan_id = new_plan(sqlite_server)
    machine = virtual(tmp_path, protocol, sqlite_server, plan_id, "--parts", str(parts))
    collector = None
    try:
        machine.wait_log("waiting READY for a reader")
        time.sleep(1.0)
        assert "part 1 made" not in machine.text()  # no reader yet: no part
        collector = collect(tmp_path, sqlite_server)
        serials = wait_stored(sqlite_server, plan_id, parts, collector)
        collector.wait_log(rf"part {parts}: stored \(part id \d+, setpoint version now \d+\)")
        assert collector.terminate() == 0
        machine.wait_log(f"all {parts} parts made")
        assert machine.terminate() == 0
    finally:
        for process in (collector, machine):
            if process is not None:
                process.kill()
    assert serials == [f"virtual-lathe/O1001/{n}" for n in range(1, parts + 1)]
    made = peaks(machine.text(), r"part (\d+) made \(setpoint version 1\): peak load (.*)")
    sent = peaks(collector.text(), r"part (\d+) \(virtual-lathe/O1001/\d+\): queued; (.*)")
    assert len(made) == parts and sent == made  # the values sent are the ones the machine made
    log = collector.text()
    assert f"starting: machine virtual-lathe, plan {plan_id} at {sqlite_server.base}" in log
    where = "reading from sequence" if protocol == "mtconnect" else "subscribed to opc.tcp://"
    assert where in log and "waiting for new parts" in log
    assert (
        f"stopped (SIGTERM): this run queued {parts} parts, sent {parts}, rejected 0, "
        "skipped 0, gaps 0; 0 pending" in log
    )
    assert f"stopped (SIGTERM): {parts} of {parts} parts made" in machine.text()
    assert "Traceback" not in log + machine.text()
    assert "Requested session timeout" not in log  # asyncua's, at an hour asked (first day)
    history = versions(sqlite_server, plan_id)
    first, last = history[0], history[-1]
    assert len(history) > 1 and last["cycle_time_min"] < first["cycle_time_min"], history


def test_a_collector_started_after_the_parts_says_it_waits_and_start_buffer_reads_them(
    sqlite_server, tmp_path
):
    parts = 3
    plan_id = new_plan(sqlite_server)
    extra = ("--parts", str(parts), "--seconds-per-part", "0.05", "--no-wait-for-reader")
    machine = virtual(tmp_path, "mtconnect", sqlite_server, plan_id, *extra)
    late = again = None
    try:
        machine.wait_log(f"all {parts} parts made")
        late = collect(tmp_path, sqlite_server)
        said = late.wait_log(
            r"reading from sequence (\d+), the agent's next: the (\d+) observations in its "
            r"buffer \(what the machine did before now\) are not read; waiting for new parts"
        )
        assert int(said[1]) > 1 and int(said[2]) == int(said[1]) - 1
        assert late.terminate() == 0
        assert "this run queued 0 parts, sent 0" in late.text()
        for name in ("collector-queue.sqlite", "collector-queue.sqlite-wal"):
            (tmp_path / name).unlink(missing_ok=True)
        config = tmp_path / "collector.toml"
        config.write_text(config.read_text() + 'start = "buffer"\n', encoding="utf-8")
        again = collect(tmp_path, sqlite_server, "--parts", str(parts))  # then it stops
        assert again.process.wait(timeout=TIMEOUT_S) == 0, again.text()[-3000:]
        serials = stored(sqlite_server, plan_id)
    finally:
        for process in (late, again, machine):
            if process is not None:
                process.kill()
    assert serials == [f"virtual-lathe/O1001/{n}" for n in range(1, parts + 1)]
    assert "reading from sequence 1, the oldest the agent holds" in again.text()
    said = f"stopped ({parts} parts sent): this run queued {parts} parts, sent {parts}"
    assert said in again.text()


@contextmanager
def listening() -> Iterator[int]:
    """A free 127.0.0.1 port, held by a listening socket while the context lasts."""
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen(1)
        yield int(held.getsockname()[1])


def _refused(tmp_path: Path, *args: str) -> str:
    answer = subprocess.run(
        [str(RCB), "virtual", "serve", *args],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert answer.returncode == 2, answer.stderr[-2000:]
    assert "Traceback" not in answer.stderr
    return answer.stderr


def test_bad_input_is_one_line_naming_the_option(tmp_path):
    demo = str(ROOT / "examples" / "ivester_demo_part.toml")
    said = _refused(tmp_path, "--protocol", "mtconnect", "--plan", demo)
    assert f"--plan = '{demo}': has no [machine.calibrations.spindle_load] table" in said
    said = _refused(tmp_path, "--protocol", "modbus", "--plan", str(PLAN))
    assert "modbus" in said and "--protocol" in said
    said = _refused(tmp_path, "--protocol", "mtconnect", "--plan", str(PLAN), "--parts", "0")
    assert "--parts" in said
    url = ("--protocol", "mtconnect", "--plan", str(PLAN), "--service-url", "127.0.0.1:8000")
    assert "--service-url = '127.0.0.1:8000': must start with http://" in _refused(tmp_path, *url)
    with listening() as port:  # a port something else listens on
        args = ("--protocol", "mtconnect", "--plan", str(PLAN), "--port", str(port))
        said = _refused(tmp_path, *args)
    assert f"--port = {port}: cannot serve on 127.0.0.1" in said


def test_the_collector_file_names_the_plan_stored_under_the_file_name(tmp_path):
    """A first-day review: the collector's file said plan 1 by default, which in a folder that
    had stored another plan first was that plan (every part then refused). Now the id is that of
    the plan of the file's name in --db; none stored is refused before anything is served."""
    url = f"sqlite:///{tmp_path / 'shop.db'}"
    migrated(url)
    args = ("--protocol", "mtconnect", "--plan", str(PLAN), "--collector", "c.toml", "--db", url)
    said = _refused(tmp_path, *args)
    assert f"--plan = '{PLAN}': no plan named 'virtual-lathe-part'" in said
    assert f"store it first (rcb plans create {PLAN} --db {url}) or give --plan-id" in said
    assert not (tmp_path / "c.toml").exists()
    engine = make_engine(url)
    create_plan(engine=engine, body=tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8")))
    second = create_plan(engine=engine, body=tomllib.loads(PLAN.read_text(encoding="utf-8")))
    engine.dispose()
    machine = subprocess.Popen(
        [str(RCB), "virtual", "serve", *args, "--port", str(free_port()), "--parts", "1"],
        cwd=tmp_path,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not (tmp_path / "c.toml").exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        written = tomllib.loads((tmp_path / "c.toml").read_text(encoding="utf-8"))
    finally:
        stop_group(machine)
    assert second.body["id"] == 2 and written["service"]["plan"] == 2


def test_the_collector_file_refuses_an_unknown_start(tmp_path):
    lines, _ = refused(tmp_path, '[mtconnect]\nurl = "http://127.0.0.1:9/x"\nstart = "oldest"')
    assert lines == ["rcb: error: mtconnect.start = 'oldest': must be one of next, buffer"]
