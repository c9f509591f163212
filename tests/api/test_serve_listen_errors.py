"""``rcb serve`` names the option that fails to listen: ``--host`` or ``--port``.

Before, every failure but a port in use named ``--port`` (``--port = 8000: cannot listen on
999.1.1.1:8000 (Name or service not known)``), though the host was what the operator mistyped.
"""

from __future__ import annotations

import errno
import socket

import pytest

from api.rest import serving
from models.errors import InputError

from conftest import invoke
from live import free_port


@pytest.mark.parametrize(
    ("host", "why"),
    [
        ("999.1.1.1", "Name or service not known"),
        ("nosuch.invalid", "Name or service not known"),
        ("192.0.2.1", "Cannot assign requested address"),  # TEST-NET-1: not this machine's
    ],
)
def test_a_host_that_cannot_be_listened_on_names_host(runner, tmp_path, host, why):
    invoke(runner, "db", "upgrade", "--db", f"sqlite:///{tmp_path / 'r.db'}")
    port = free_port()
    done = invoke(
        runner,
        "serve",
        "--host",
        host,
        "--port",
        str(port),
        "--db",
        f"sqlite:///{tmp_path / 'r.db'}",
    )
    assert done.exit_code == 2
    assert done.stderr == f"rcb: error: --host = {host!r}: cannot listen on {host}:{port} ({why})\n"


def test_a_port_without_permission_names_port(monkeypatch):
    def refused(_sock: socket.socket, _address: object) -> None:
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(socket.socket, "bind", refused)
    with pytest.raises(InputError) as caught:
        serving.tcp_listener("127.0.0.1", 80)
    assert str(caught.value) == "--port = 80: cannot listen on 127.0.0.1:80 (Permission denied)"
