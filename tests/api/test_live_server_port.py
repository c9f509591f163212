"""The tests' live server starts on a port of its own even when its drawn port is taken.

``LiveServer`` draws a free port, then migrates and makes keys before ``rcb serve`` binds
it: another worker's server can take it in between. In CI that made a module's every test
401 (its client talked to the other server, whose keys are not these). A port taken is
drawn again, and the server is ours once its own log says it listens (tests/live.py).
Ports are drawn under the kernel's ephemeral range, where no outgoing connection takes
one, each xdist worker from a block of its own.
"""

from __future__ import annotations

import socket
from pathlib import Path

import live
from live import LiveServer, free_port


def test_a_server_whose_port_is_taken_starts_on_another_and_is_ours(tmp_path) -> None:
    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        taken = other.getsockname()[1]
        server = LiveServer(f"sqlite:///{tmp_path / 'rcb.db'}", tmp_path / "serve.log")
        server.port, server.base = taken, f"http://127.0.0.1:{taken}/api/v1"
        server.start()
        try:
            assert server.port != taken
            with server.client("viewer") as c:
                assert c.get("/plans").status_code == 200  # this database's key
            assert "is already in use by another process" in (tmp_path / "serve.log").read_text()
        finally:
            server.stop()


def test_ports_are_drawn_under_the_ephemeral_range_and_one_in_use_is_skipped() -> None:
    ephemeral_from = int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    first = free_port()
    block = first - (first - live._PORTS_FROM) % live._BLOCK
    coming = block + live._drawn["next"] % live._BLOCK
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", coming))
        busy.listen()
        second = free_port()
    assert first < ephemeral_from and second < ephemeral_from
    assert second not in (first, coming)
    assert block <= second < block + live._BLOCK
