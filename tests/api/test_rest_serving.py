"""``rcb serve`` as a process: workers die with their master, a taken port is one line.

Issue 17 item 8: with ``--workers 2``, ``kill -9`` of the master left both workers serving and
the port taken (a restart failed with "Address already in use"); on a taken port ``rcb serve``
said it was serving, then failed, and exited 3 (which means infeasible).
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import httpx
import pytest

from api.rest.serving import EXIT_PORT_IN_USE

from live import RCB, LiveServer

#: Seconds the workers have to exit after their master is killed.
ORPHAN_GRACE_S = 10.0


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie nobody reaped has exited and holds no socket)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _children(pid: int) -> list[int]:
    """The pids whose parent is ``pid``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except (FileNotFoundError, ProcessLookupError):
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _wait_for_workers(live: LiveServer, timeout_s: float = 90.0) -> list[int]:
    """The master's worker pids once every worker has started."""
    assert live.process is not None
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        log = live.log.read_text(encoding="utf-8", errors="replace")
        workers = [p for p in _children(live.process.pid) if _alive(p)]
        # multiprocessing's spawn also starts a resource tracker; the workers log startup
        if log.count("Application startup complete.") >= live.workers:
            return workers
        time.sleep(0.1)
    raise AssertionError(f"not all workers started: {live.log.read_text()[-3000:]}")


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads processes from /proc (Linux)")
def test_workers_exit_when_the_master_is_killed_and_the_port_is_free_at_once(tmp_path):
    live = LiveServer(f"sqlite:///{tmp_path / 'w.db'}", tmp_path / "serve.log", workers=2)
    live.start()
    assert live.process is not None
    group = live.process.pid
    try:
        children = _wait_for_workers(live)
        workers = [p for p in children if _alive(p)]
        assert len(workers) >= 2  # two workers (and multiprocessing's resource tracker)
        os.kill(live.process.pid, signal.SIGKILL)  # the master only, not its process group
        live.process.wait(timeout=10)
        killed_at = time.monotonic()
        while any(_alive(p) for p in workers) and time.monotonic() - killed_at < ORPHAN_GRACE_S:
            time.sleep(0.05)
        left = [p for p in workers if _alive(p)]
        assert left == [], f"workers {left} outlived their master by {ORPHAN_GRACE_S} s"
        with pytest.raises(httpx.HTTPError):
            httpx.get(f"{live.base}/health", timeout=2.0)  # nobody serves the port
        # a new server binds the same port at once
        live.process = None
        live.start()
        with live.client("viewer") as client:
            assert client.get("/health").status_code == 200
    finally:
        live.stop()
        try:
            os.killpg(group, signal.SIGKILL)  # anything the old master left
        except ProcessLookupError:
            pass


@pytest.mark.parametrize("workers", [1, 2])
def test_a_taken_port_exits_with_its_own_code_and_one_line(tmp_path, workers):
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run(
            [str(RCB), "serve", "--db", f"sqlite:///{tmp_path / 'p.db'}"]
            + ["--port", str(port), "--workers", str(workers)],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert done.returncode == EXIT_PORT_IN_USE == 5
    assert done.stdout == ""
    assert done.stderr.splitlines() == [
        f"rcb: error: --port = {port}: 127.0.0.1:{port} is already in use by another process"
    ]
