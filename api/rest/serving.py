"""Running the REST service under uvicorn, one process or several workers.

The listening socket is bound here, before anything says it is serving: a port in use is
:class:`PortInUseError` (``rcb serve`` exits with :data:`EXIT_PORT_IN_USE` and one line).

With several workers uvicorn (0.54) binds the shared listening socket with protocol 0, and
asyncio sets ``TCP_NODELAY`` only on sockets whose protocol is ``IPPROTO_TCP``; every answer on
a kept-alive connection then waits for the client's delayed ACK, about 40 ms on Linux
(Kludex/uvicorn issue #3149; measured here: ``GET /health`` 44 ms with 2 workers against
0.8 ms with one). So the listener is bound here, as a TCP socket, and handed to uvicorn's
server (one worker) or its worker supervisor (several).

A worker dies with its master: uvicorn's workers are spawned processes that outlive a master
killed with ``kill -9``, keep serving and keep the port, so a restart cannot bind it. Each
worker asks Linux for ``SIGTERM`` when its parent dies (``prctl(PR_SET_PDEATHSIG)``,
prctl(2)) and then shuts down as uvicorn does on ``SIGTERM`` (in-flight requests finish, the
listener is closed); elsewhere a thread watches the parent's pid (:func:`die_with_parent`).

uvicorn uses uvloop and httptools (project dependencies) when they are installed: with 4 MES
clients on 2 workers most of a worker's CPU went to asyncio's loop, h11 and FastAPI rather
than to the report itself, and these two took about 6 % off the server's CPU per report
(README, REST load).
"""

from __future__ import annotations

import ctypes
import errno
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
from typing import TYPE_CHECKING, Any

import uvicorn
from uvicorn.supervisors import Multiprocess

from api.rest import connections
from api.rest.connections import raise_file_limit
from api.settings import hand_to_workers, http_limits
from models.errors import InputError

if TYPE_CHECKING:
    from fastapi import FastAPI

#: The uvicorn factory the workers import; it reads the database URL from the environment
#: (:mod:`api.settings`) and ties the worker's life to its master's.
APP = "api.rest.serving:worker_app"
#: The exit code of ``rcb serve`` when its port is taken (2 bad input, 3 infeasible, 4 solver).
EXIT_PORT_IN_USE = 5
#: uvicorn's exit code when the app did not start (kept as ``uvicorn.run`` returns it).
EXIT_STARTUP_FAILURE = 3
#: Seconds between two looks at the parent's pid where there is no parent-death signal.
PARENT_POLL_S = 0.5
#: Seconds a thread holds the GIL while another waits for it (Python's default 0.005). A
#: report's thread gives up the GIL at every database call; behind a thread computing a
#: history it then waited up to 5 ms each time (mixed load, README: 8 % -> 20 % of the MES
#: throughput kept on SQLite with the bounded read pool).
SWITCH_INTERVAL_S = 0.0005
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
#: What ``bind`` says when the host, not the port, cannot be listened on: an address not of
#: this machine, a family it does not have (a name it cannot resolve is ``socket.gaierror``).
_HOST_ERRNOS = (errno.EADDRNOTAVAIL, errno.EAFNOSUPPORT)


class PortInUseError(InputError):
    """The address and port to serve on are taken by another process."""


def run(
    listener: socket.socket, url: str, *, workers: int, access_log: bool, forwarded: str
) -> None:
    """Serve the app on ``url`` through ``listener`` (:func:`tcp_listener`) until interrupted.

    Parameters
    ----------
    listener : socket.socket
        The bound, listening socket; it is closed when serving ends.
    url : str
        SQLAlchemy URL of the (migrated) database.
    workers : int
        Worker processes; 1 serves in this process.
    access_log : bool
        Log every request.
    forwarded : str
        The proxies trusted to name the client (:func:`api.settings.trusted_proxies`;
        empty: none, the peer is the client).
    """
    hand_to_workers(url)  # the workers' factory reads it
    raise_file_limit()  # inherited by the workers: room for the connections they may hold
    host, port = listener.getsockname()[:2]
    options: dict[str, Any] = {
        # deadlines and caps of the connections (api.rest.connections, RCB_HTTP_*)
        "http": connections.PROTOCOL,
        "timeout_keep_alive": http_limits().keep_alive_timeout_s,
        "factory": True,
        "host": host,
        "port": port,
        "workers": workers,
        "access_log": access_log,
        "log_level": "info",
        # a worker imports cvxpy (about 2 s) before it answers; two starting at once on a
        # busy 2-core machine can miss uvicorn's default 5 s and be restarted
        "timeout_worker_healthcheck": 30,
        # X-Forwarded-For read only from these peers (uvicorn's ProxyHeadersMiddleware)
        "proxy_headers": bool(forwarded),
        "forwarded_allow_ips": forwarded or None,
    }
    config = uvicorn.Config(APP, **options)
    try:
        if workers == 1:
            server = uvicorn.Server(config)
            server.run(sockets=[listener])
            if not server.started:
                sys.exit(EXIT_STARTUP_FAILURE)
        else:
            Multiprocess(config, sockets=[listener]).run()
    finally:
        listener.close()


def tcp_listener(host: str, port: int) -> socket.socket:
    """A bound, listening, inheritable ``IPPROTO_TCP`` socket on ``host``:``port``.

    Raises
    ------
    PortInUseError
        Another process listens on the port.
    InputError
        The address cannot be listened on for another reason: naming ``--host`` when the host
        is what fails (not a name or address, not this machine's), ``--port`` otherwise (a
        port below 1024 without the permission).
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(2048)  # uvicorn's backlog; listening now reports a port in use here
    except OSError as err:
        sock.close()
        if err.errno == errno.EADDRINUSE:
            raise PortInUseError(
                "--port", port, f"{host}:{port} is already in use by another process"
            ) from None
        host_failed = isinstance(err, socket.gaierror) or err.errno in _HOST_ERRNOS
        field, value = ("--host", host) if host_failed else ("--port", port)
        raise InputError(field, value, f"cannot listen on {host}:{port} ({err.strerror})") from None
    sock.set_inheritable(True)
    return sock


def worker_app() -> FastAPI:
    """The app on ``$RCB_DATABASE_URL``, in a worker that exits when its master dies.

    The worker also switches threads more often (:data:`SWITCH_INTERVAL_S`).
    """
    from api.rest.app import app_from_env

    sys.setswitchinterval(SWITCH_INTERVAL_S)
    parent = multiprocessing.parent_process()
    if parent is not None and parent.pid is not None:  # a worker of ``--workers N``
        die_with_parent(parent.pid)
    return app_from_env()


def die_with_parent(parent_pid: int) -> None:
    """Have this process receive ``SIGTERM`` when process ``parent_pid`` (its parent) dies.

    Parameters
    ----------
    parent_pid : int
        The pid of the parent; if it is no longer the parent (it died before this call), the
        signal is sent at once.
    """
    if not _parent_death_signal(signal.SIGTERM):
        threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before the signal was asked for
        os.kill(os.getpid(), signal.SIGTERM)


def _parent_death_signal(signum: int) -> bool:
    """Ask Linux for ``signum`` when the parent dies; False where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return bool(libc.prctl(_PR_SET_PDEATHSIG, signum, 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


def _watch_parent(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(PARENT_POLL_S)
    os.kill(os.getpid(), signal.SIGTERM)
