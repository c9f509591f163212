"""A real PgBouncer (Debian's package) in transaction pooling before a fresh test database.

Shared by the PgBouncer tests (``tests/db/test_pgbouncer.py``) and the two-instance tests
(``tests/api/test_two_instances.py``). PgBouncer runs as ``nobody`` when the tests run as
root (it refuses root), from a configuration in a temporary folder, on a free port.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from sqlalchemy import text
from sqlalchemy.engine import make_url

from db.engine import make_engine

from live import free_port

PGBOUNCER = shutil.which("pgbouncer") or (
    "/usr/sbin/pgbouncer" if Path("/usr/sbin/pgbouncer").exists() else None
)


@contextmanager
def pgbouncer(direct: str, log: Path, server_pool: int) -> Iterator[str]:
    """PgBouncer before the database of ``direct``, at most ``server_pool`` server
    connections to it: the service's URL through it (``?pgbouncer=transaction``)."""
    if PGBOUNCER is None:
        pytest.skip("no pgbouncer (Debian's package pgbouncer; .ci/run installs it as root)")
    folder = Path(tempfile.mkdtemp(prefix="pgbouncer-"))
    folder.chmod(0o755)  # read by the unprivileged user it runs as under root
    port = free_port()
    target = make_url(direct)
    (folder / "pgbouncer.ini").write_text(
        "[databases]\n"
        f"rcb = host={target.host} port={target.port} dbname={target.database} "
        f"user={target.username}\n"
        "[pgbouncer]\n"
        f"listen_addr = 127.0.0.1\nlisten_port = {port}\nunix_socket_dir =\n"
        "auth_type = any\npool_mode = transaction\n"
        f"default_pool_size = {server_pool}\nmax_client_conn = 200\n"
        "ignore_startup_parameters = extra_float_digits,options\n"
    )
    user = ["-u", "nobody"] if os.geteuid() == 0 else []
    process = subprocess.Popen(
        [PGBOUNCER, *user, str(folder / "pgbouncer.ini")],
        stdout=subprocess.DEVNULL,
        stderr=log.open("wb"),
    )
    try:
        _wait_for(port, process, log)
        yield f"postgresql+psycopg://{target.username}@127.0.0.1:{port}/rcb?pgbouncer=transaction"
    finally:
        process.terminate()
        process.wait(timeout=30)
        shutil.rmtree(folder, ignore_errors=True)


def _wait_for(port: int, process: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"pgbouncer exited: {log.read_text()}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.1)
    raise RuntimeError(f"pgbouncer did not listen: {log.read_text()}")


class ConnectionPeak:
    """The most connections PostgreSQL held to the database of ``direct`` at once, sampled
    every 20 ms, in phases (:meth:`phase` starts the next); ``direct`` None: nothing."""

    def __init__(self, direct: str | None) -> None:
        self.direct, self.peaks = direct, [0]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def phase(self) -> None:
        self.peaks.append(0)

    def __enter__(self) -> ConnectionPeak:
        if self.direct is not None:
            self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(10)

    def _sample(self) -> None:
        engine = make_engine(str(self.direct))
        query = text(
            "SELECT count(*) FROM pg_stat_activity"
            " WHERE datname = current_database() AND pid <> pg_backend_pid()"
        )
        with engine.connect() as connection:
            while not self._stop.wait(0.02):
                count = int(connection.execute(query).scalar_one())
                self.peaks[-1] = max(self.peaks[-1], count)
                connection.rollback()
        engine.dispose()
