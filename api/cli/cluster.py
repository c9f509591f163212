"""Scenarios on a Dask cluster: ``rcb certify --scheduler ADDRESS``.

A plant with hundreds of plans, or a fault catalogue of 1000 scenarios each, outgrows one
host's cores. Dask's ``distributed`` scheduler is the field's engine for spreading such
independent Python tasks over hosts: :func:`cluster_executor` connects to a running scheduler
(``dask scheduler`` on one host, ``dask worker tcp://HOST:8786`` on each of the others, every
worker with this project installed) and hands :func:`supervisor.virtual.certify.simulate` its
``concurrent.futures`` executor. A scenario depends only on its seed, so the certificate is the
same as with local workers, bit for bit (``tests/supervisor/test_certify_cluster.py``).

``distributed`` is an optional extra (``pip install -e ".[cluster]"``): the rest of ``rcb``
never imports it.
"""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import Executor
from contextlib import contextmanager
from typing import Any

from models.errors import InputError

#: Seconds to wait for the scheduler to answer before saying it does not.
CONNECT_TIMEOUT_S = 10
#: The longest scheduler address accepted (``tcp://`` and a host name and port).
MAX_ADDRESS = 300


@contextmanager
def cluster_executor(address: str) -> Iterator[tuple[Executor, int]]:
    """The executor of the Dask scheduler at ``address`` and its worker threads.

    Raises
    ------
    InputError
        ``distributed`` is not installed, the address is malformed, or no scheduler answers
        there within :data:`CONNECT_TIMEOUT_S` (naming ``--scheduler``).
    """
    if not address.strip() or len(address) > MAX_ADDRESS:
        raise InputError("--scheduler", address, f"must be 1 to {MAX_ADDRESS} characters")
    try:
        from distributed import Client as _Client
    except ImportError:
        why = "needs Dask's distributed: pip install -e '.[cluster]' (rcb-supervisor[cluster])"
        raise InputError("--scheduler", address, why) from None
    try:
        connect: Any = _Client  # distributed has no type hints
        client = connect(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as err:
        why = f"no Dask scheduler answers there ({type(err).__name__}: {err})"
        raise InputError("--scheduler", address, why) from None
    try:
        yield client.get_executor(), _threads(client.scheduler_info())
    finally:
        client.close()


def _threads(info: dict[str, Any]) -> int:
    """The worker threads the scheduler knows of (at least 1: tasks wait for a worker)."""
    workers = info.get("workers", {})
    return max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
