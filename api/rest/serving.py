"""Running the REST service under uvicorn, one process or several workers.

With several workers uvicorn (0.54) binds the shared listening socket with protocol 0, and
asyncio sets ``TCP_NODELAY`` only on sockets whose protocol is ``IPPROTO_TCP``; every answer on
a kept-alive connection then waits for the client's delayed ACK, about 40 ms on Linux
(Kludex/uvicorn issue #3149; measured here: ``GET /health`` 44 ms with 2 workers against
0.8 ms with one). So the listener for several workers is bound here, as a TCP socket, and
handed to uvicorn's own worker supervisor; one worker runs uvicorn as it is.

uvicorn uses uvloop and httptools (project dependencies) when they are installed: with 4 MES
clients on 2 workers most of a worker's CPU went to asyncio's loop, h11 and FastAPI rather
than to the report itself, and these two took about 6 % off the server's CPU per report
(README, REST load).
"""

from __future__ import annotations

import socket
from typing import Any

import uvicorn
from uvicorn.supervisors import Multiprocess

from api.settings import hand_to_workers
from models.errors import InputError

#: The uvicorn factory the workers import; it reads the database URL from the environment
#: (:mod:`api.settings`).
APP = "api.rest.app:app_from_env"


def run(url: str, *, host: str, port: int, workers: int, access_log: bool) -> None:
    """Serve the app on ``url`` until interrupted."""
    hand_to_workers(url)  # the workers' factory reads it
    options: dict[str, Any] = {
        "factory": True,
        "host": host,
        "port": port,
        "workers": workers,
        "access_log": access_log,
        "log_level": "info",
        # a worker imports cvxpy (about 2 s) before it answers; two starting at once on a
        # busy 2-core machine can miss uvicorn's default 5 s and be restarted
        "timeout_worker_healthcheck": 30,
    }
    if workers == 1:
        uvicorn.run(APP, **options)
        return
    config = uvicorn.Config(APP, **options)
    listener = tcp_listener(host, port)
    try:
        Multiprocess(config, sockets=[listener]).run()
    finally:
        listener.close()


def tcp_listener(host: str, port: int) -> socket.socket:
    """A bound, inheritable ``IPPROTO_TCP`` listening socket (uvicorn listens on it)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(2048)  # uvicorn's backlog; listening now reports a port in use here
    except OSError as err:
        sock.close()
        raise InputError(
            "--port", port, f"cannot listen on {host}:{port} ({err.strerror})"
        ) from None
    sock.set_inheritable(True)
    return sock
