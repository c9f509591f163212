"""Serve the virtual lathe over a protocol and make its parts at a pace, until stopped.

The machine waits ``READY`` until a reader is there (an MTConnect ``/sample`` request, an OPC
UA subscription with a monitored item), unless told not to; then it makes one part every
``seconds_per_part`` (each part's samples are published at once when it is made), logs each
part with its peak spindle load per operation, and after the last part stays ``READY``, still
serving, until SIGTERM or SIGINT.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType

from api.virtual_serve.lathe import SETPOINT_VERSION, VirtualLathe
from api.virtual_serve.mtconnect_agent import Agent, observations_per_sample, serve

log = logging.getLogger("rcb.virtual")
#: The agent's buffer (cppagent's default, 2^17 observations).
BUFFER_SIZE = 131072
#: How often an OPC UA server is asked whether a client subscribes [s].
_LOOK_S = 0.2


@dataclass(frozen=True)
class Published:
    """A machine being served: where, how to publish up to a sample, whether a reader came."""

    url: str
    release: Callable[[int], None]  # make the first n samples of the trace public
    reader: Callable[[], bool]
    close: Callable[[], None]


def mtconnect(lathe: VirtualLathe, port: int) -> Published:
    """The lathe as an MTConnect agent on 127.0.0.1:``port`` (device ``lathe``)."""
    found, made = observations_per_sample(lathe.trace)
    agent = Agent(found, BUFFER_SIZE)
    asked = threading.Event()
    server, url = serve(agent, port, on_sample=asked.set)
    agent.release(made[0])  # the machine READY before its first part

    def close() -> None:
        server.shutdown()
        server.server_close()

    return Published(url, lambda n: agent.release(made[n - 1]), asked.is_set, close)


def opcua(lathe: VirtualLathe, port: int) -> Published:
    """The lathe as an OPC UA server at ``opc.tcp://127.0.0.1:port/rcb/`` (OPC 40502 names)."""
    from api.virtual_serve.opcua_machine import OpcUaMachine  # asyncua: only when served

    machine = OpcUaMachine(lathe.trace, port)
    machine.start()
    return Published(machine.url, lambda n: machine.play(n), machine.watched, machine.stop)


def make_parts(
    lathe: VirtualLathe,
    published: Published,
    seconds_per_part: float,
    wait_for_reader: bool,
    stop: threading.Event,
) -> int:
    """Make the parts at their pace until done or ``stop``; how many were made."""
    if wait_for_reader:
        log.info("waiting READY for a reader (rcb collect) before the first part")
        while not published.reader():
            if stop.wait(_LOOK_S):
                return 0
        log.info("a reader is there: making %d parts", len(lathe.part_ends))
    for part, end in enumerate(lathe.part_ends, start=1):
        if stop.wait(seconds_per_part):
            return part - 1
        published.release(end)
        peaks = ", ".join(f"{name} {v:.4g} V" for name, v in lathe.peaks(part).items())
        log.info("part %d made (setpoint version %d): peak load %s", part, SETPOINT_VERSION, peaks)
    log.info("all %d parts made; READY and serving until stopped", len(lathe.part_ends))
    return len(lathe.part_ends)


def run(
    lathe: VirtualLathe,
    published: Published,
    seconds_per_part: float,
    wait_for_reader: bool,
) -> int:
    """Make the parts, serve until SIGTERM/SIGINT, close; how many parts were made."""
    stop = threading.Event()
    caught: list[str] = []

    def on_signal(number: int, frame: FrameType | None) -> None:
        caught.append(signal.Signals(number).name)
        stop.set()

    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, on_signal)
    made = 0
    try:
        made = make_parts(lathe, published, seconds_per_part, wait_for_reader, stop)
        while not stop.wait(1.0):
            pass
    finally:
        published.close()
    why = caught[0] if caught else "stop"
    log.info("stopped (%s): %d of %d parts made", why, made, len(lathe.part_ends))
    return made
