"""A real ``rcb serve`` process on 127.0.0.1 for REST tests, and an httpx client for it."""

from __future__ import annotations

import os
import signal
import socket
import ssl
import subprocess
import sys
import time
from pathlib import Path

import httpx

from api.rest.serving import EXIT_PORT_IN_USE
from api.services.keys import create_key
from db.engine import make_engine

from migrated import migrated

RCB = Path(sys.executable).with_name("rcb")
ROLES = ("mes", "engineer", "viewer")

#: The one TLS context of every client the tests make. Every address here is plain http on
#: 127.0.0.1, yet httpx builds a context per client, loading the CA bundle each time: 57 s
#: of CPU over a full run (py-spy, 2026-12-05), 4 % of the suite.
LOOPBACK_TLS = ssl.create_default_context()


# Ports are drawn under Linux's ephemeral range (32768-60999), where no client connection
# (to PostgreSQL, to a server under test) takes one between the draw and the bind, each
# xdist worker from a block of its own, so two workers never draw the same port.
_PORTS_FROM, _BLOCK, _BLOCKS = 20_000, 1_000, 12
_drawn = {"next": os.getpid() % _BLOCK}


def _worker() -> int:
    """This xdist worker's number (``gw3`` is 3), 0 outside xdist."""
    name = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    return int(name[2:]) if name[2:].isdigit() else 0


def free_port() -> int:
    """A port on 127.0.0.1 nothing listens on, from this worker's block, never the last one drawn.

    A port drawn by binding port 0 comes from the ephemeral range, which the kernel also
    hands to outgoing connections: one made between the draw and the server's bind took
    the port (a CI flake). The blocks stay under that range; a port in use (a service, a
    socket in TIME_WAIT) is skipped.
    """
    first = _PORTS_FROM + (_worker() % _BLOCKS) * _BLOCK
    for _ in range(_BLOCK):
        port = first + _drawn["next"] % _BLOCK
        _drawn["next"] += 1
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    raise RuntimeError(f"no free port in {first}-{first + _BLOCK - 1}")


def kill_group(process: subprocess.Popen[bytes]) -> None:
    """``kill -9`` a process started in its own session, and its group: no shutdown."""
    os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=10)


def stop_group(process: subprocess.Popen[bytes]) -> None:
    """Graceful stop of a process group (SIGTERM), SIGKILL if it hangs."""
    os.killpg(process.pid, signal.SIGTERM)
    try:
        process.wait(timeout=15)
    except subprocess.TimeoutExpired:
        kill_group(process)


class LiveServer:
    """``rcb serve --db URL`` in its own process group; ``keys`` holds one API key per role."""

    def __init__(self, url: str, log: Path, workers: int = 1, args: tuple[str, ...] = ()) -> None:
        self.url, self.log, self.workers, self.args = url, log, workers, args
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}/api/v1"
        self.process: subprocess.Popen[bytes] | None = None
        migrated(url)
        engine = make_engine(url)
        self.keys = {r: create_key(engine=engine, role=r)["key"] for r in ROLES}
        engine.dispose()

    def start(self, timeout_s: float = 60.0, attempts: int = 5) -> None:
        """Start the server and wait until it answers on the port it listens on.

        The port was free when drawn, but another worker's server may bind it first: then
        ``rcb serve`` exits naming it (exit 5), and a health check alone could be answered by
        that other server, whose database and keys are not this one's (seen in CI: a module's
        every test 401). The server is ours once its own log says it listens (``rcb:
        serving``, printed once its socket is bound) and the port answers; a port taken is
        drawn again, ``attempts`` times at most.
        """
        for attempt in range(attempts):
            if attempt:
                self.port = free_port()
                self.base = f"http://127.0.0.1:{self.port}/api/v1"
            if self._started(timeout_s):
                return
        raise RuntimeError(f"rcb serve found no free port in {attempts} tries: {self._tail()}")

    def _started(self, timeout_s: float) -> bool:
        """True once ours answers; False if its port was taken; raises on any other failure."""
        command = [str(RCB), "serve", "--db", self.url, "--port", str(self.port)]
        command += ["--workers", str(self.workers), "--no-access-log", *self.args]
        offset = self.log.stat().st_size if self.log.exists() else 0
        with self.log.open("ab") as log:
            self.process = subprocess.Popen(
                command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
            )
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                code, self.process = self.process.returncode, None
                if code == EXIT_PORT_IN_USE:
                    return False
                raise RuntimeError(f"rcb serve exited: {self._tail()}")
            listening = "rcb: serving" in self.log.read_bytes()[offset:].decode(errors="replace")
            try:
                if (
                    listening
                    and httpx.get(
                        f"{self.base}/health", timeout=1.0, verify=LOOPBACK_TLS
                    ).status_code
                    == 200
                ):
                    return True
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        self.stop()
        raise RuntimeError(f"rcb serve did not answer in {timeout_s} s: {self._tail()}")

    def _tail(self) -> str:
        """The end of the server's log."""
        return self.log.read_text()[-3000:]

    def kill(self) -> None:
        """``kill -9`` the whole server (process group): no shutdown, no cleanup."""
        if self.process is not None:
            kill_group(self.process)
            self.process = None

    def stop(self) -> None:
        """Graceful stop (SIGTERM), SIGKILL if it hangs."""
        if self.process is not None:
            stop_group(self.process)
            self.process = None

    def client(
        self, role: str | None = "engineer", headers: dict[str, str] | None = None
    ) -> httpx.Client:
        """A client sending the key of ``role`` (None: no key) and ``headers``."""
        sent = {"Authorization": f"Bearer {self.keys[role]}"} if role else {}
        return httpx.Client(
            base_url=self.base,
            headers={**sent, **(headers or {})},
            timeout=60.0,
            verify=LOOPBACK_TLS,
        )
