"""The service under load: a fresh benchmark database and ``rcb serve`` on a free port."""

from __future__ import annotations

import json
import os
import secrets
import signal
import socket
import subprocess
import time
from pathlib import Path

import httpx

from benchmarks.api_load.config import PREFIX, RCB, ROOT
from benchmarks.api_load.cpu import descendants


class Postgres:
    """A benchmark database on the PostgreSQL server of ``admin_url``, dropped by ``drop``."""

    def __init__(self, admin_url: str) -> None:
        from sqlalchemy import create_engine
        from sqlalchemy.engine import make_url

        self.name = f"rcb_bench_{secrets.token_hex(6)}"
        self.admin = create_engine(admin_url, isolation_level="AUTOCOMMIT", pool_pre_ping=True)
        self.url = make_url(admin_url).set(database=self.name).render_as_string(False)
        self.created = False

    def create(self) -> None:
        from sqlalchemy import text

        with self.admin.connect() as connection:
            connection.execute(text(f'CREATE DATABASE "{self.name}"'))
        self.created = True

    def backend_pids(self) -> list[int]:
        from sqlalchemy import text

        with self.admin.connect() as connection:
            rows = connection.execute(
                text("SELECT pid FROM pg_stat_activity WHERE datname = :d"), {"d": self.name}
            )
            return [int(r[0]) for r in rows]

    def sessions(self) -> int:
        """Sessions (connections) opened on the benchmark database so far (PostgreSQL >= 14;
        the statistics lag by up to a second)."""
        from sqlalchemy import text

        with self.admin.connect() as connection:
            value = connection.execute(
                text("SELECT sessions FROM pg_stat_database WHERE datname = :d"), {"d": self.name}
            ).scalar()
        return int(value or 0)

    def drop(self) -> None:
        from sqlalchemy import text

        if self.created:
            with self.admin.connect() as connection:
                connection.execute(text(f'DROP DATABASE IF EXISTS "{self.name}" WITH (FORCE)'))
            self.created = False
        self.admin.dispose()


# --------------------------------------------------------------------------- the server


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def create_key(url: str, role: str) -> str:
    """A new API key of ``role`` from ``rcb keys create`` (migrates the database first)."""
    proc = subprocess.run(
        [str(RCB), "keys", "create", "--role", role, "--label", "api_load", "--db", url, "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=False,
    )
    if proc.returncode != 0:
        raise RuntimeError(f"rcb keys create failed (exit {proc.returncode}): {proc.stderr}")
    return str(json.loads(proc.stdout)["key"])


class Server:
    """``rcb serve`` in its own process group on 127.0.0.1 and a free port."""

    def __init__(self, url: str, workers: int, log: Path) -> None:
        self.url, self.workers, self.log = url, workers, log
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}{PREFIX}"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self, timeout_s: float = 120.0) -> None:
        command = [str(RCB), "serve", "--db", self.url, "--port", str(self.port)]
        command += ["--workers", str(self.workers), "--no-access-log"]
        with self.log.open("ab") as log:
            self.process = subprocess.Popen(
                command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, cwd=ROOT
            )
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"rcb serve exited: {self.log_tail()}")
            try:
                if httpx.get(f"{self.base}/health", timeout=1.0).status_code == 200:
                    if len(self.worker_pids()) >= self.workers:
                        return
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        raise RuntimeError(f"rcb serve did not answer in {timeout_s} s: {self.log_tail()}")

    def worker_pids(self) -> list[int]:
        """The processes serving requests: the workers, or the server itself with one."""
        if self.process is None:
            return []
        if self.workers == 1:
            return [self.process.pid]
        kids = descendants(self.process.pid)
        # uvicorn's workers are multiprocessing "spawn" children running uvicorn; skip helpers
        # such as multiprocessing's resource tracker (they use no CPU under load anyway)
        return [pid for pid in kids if "resource_tracker" not in _cmdline(pid)]

    def log_tail(self, lines: int = 30) -> str:
        try:
            return "\n".join(self.log.read_text(errors="replace").splitlines()[-lines:])
        except OSError:
            return "(no log)"

    def stop(self) -> None:
        """SIGTERM the process group, SIGKILL if it hangs."""
        if self.process is None:
            return
        try:
            os.killpg(self.process.pid, signal.SIGTERM)
            self.process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=10)
        except ProcessLookupError:
            pass
        self.process = None


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""
