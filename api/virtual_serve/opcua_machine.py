"""An OPC UA server on 127.0.0.1 (asyncua) playing a virtual lathe's trace.

``rcb virtual serve --protocol opcua`` serves it (:mod:`api.virtual_serve.run`); the collector's
tests start it in a thread.

Its address space is built by a ``space`` function: :func:`own_space` (here) or
``tests/opcua_nodesets.py``'s, built from the OPC Foundation's own nodesets. :func:`own_space`
follows OPC 40502 (CNC Systems) where it defines the signals: under
``Objects/CncInterface`` (namespace ``http://opcfoundation.org/UA/CNC``) a spindle
``CncSpindleList/Spindle`` with ``ActLoad`` and ``ActSpeed`` and a channel
``CncChannelList/Channel`` with ``ActFeedrate``, ``ActProgramBlock`` and ``ActStatus``
(CncChannelStatus: 0 Reset, 2 Active). What the specification does not place (part count, tool
number, program name) is under ``Objects/Machine`` in the test's own namespace. Each sample of
the trace is written with its own ``SourceTimestamp`` (1 ms apart), changed values only, the
load every sample; the server runs in its own thread and event loop.
"""

from __future__ import annotations

import asyncio
import datetime as dt
import threading
import time
from collections.abc import Awaitable, Callable
from typing import Any

from asyncua import ua
from asyncua.server.server import Server

from supervisor.virtual.trace import TraceSample

CNC = "http://opcfoundation.org/UA/CNC"  # as Opc.Ua.CNC.NodeSet.xml has it
PROGRAM = "O1001"
#: The longest a start may take before it counts as hung [s] (:meth:`OpcUaMachine.start`).
START_BOUND_S = 600.0
_BASE = ua.DateTime(2026, 11, 25, tzinfo=dt.UTC)  # asyncua's datetime, as DataValue declares


#: item → (node, its VariantType, whether its value is an array: OPC 40502's ActProgramBlock)
Nodes = dict[str, tuple[Any, ua.VariantType, bool]]
#: Builds a server's address space (before it starts) → the node of every signal.
Space = Callable[[Server, TraceSample], Awaitable[Nodes]]


async def own_space(server: Server, first: TraceSample) -> Nodes:
    """The BrowseNames of OPC 40502 in a namespace of its own (see the module docstring)."""
    cnc = await server.register_namespace(CNC)
    own = await server.register_namespace("urn:rcb-supervisor:test-lathe")
    interface = await server.nodes.objects.add_object(cnc, "CncInterface")
    spindle = await (await interface.add_object(cnc, "CncSpindleList")).add_object(own, "Spindle")
    channel = await (await interface.add_object(cnc, "CncChannelList")).add_object(own, "Channel")
    machine = await server.nodes.objects.add_object(own, "Machine")
    nodes: Nodes = {}
    for item, parent, ns, name, value, kind in (
        ("execution", channel, cnc, "ActStatus", 0, ua.VariantType.Int32),
        ("program", machine, own, "ProgramName", PROGRAM, ua.VariantType.String),
        ("part_count", machine, own, "PartCount", first.part_count, ua.VariantType.UInt32),
        ("tool_number", machine, own, "ToolNumber", first.tool_number, ua.VariantType.UInt32),
        ("block", channel, cnc, "ActProgramBlock", "", ua.VariantType.String),
        ("spindle_speed_rpm", spindle, cnc, "ActSpeed", 0.0, ua.VariantType.Double),
        ("feed_rate_mm_min", channel, cnc, "ActFeedrate", 0.0, ua.VariantType.Double),
        ("spindle_load", spindle, cnc, "ActLoad", 0.0, ua.VariantType.Double),
    ):
        node = await parent.add_variable(ns, name, ua.Variant(value, kind))
        nodes[item] = (node, kind, False)
    return nodes


class OpcUaMachine:
    """``start()`` serves the trace's first sample; ``play(until)`` writes on; ``stop()``."""

    def __init__(
        self, trace: list[TraceSample], port: int, start_at: int = 0, space: Space = own_space
    ) -> None:
        """Serve ``trace`` from sample ``start_at`` (a machine that was running while down)."""
        self.trace, self.port, self.start_at, self.space = trace, port, start_at, space
        self.url = f"opc.tcp://127.0.0.1:{port}/rcb/"
        self.loop = asyncio.new_event_loop()
        self.ready, self.done = threading.Event(), threading.Event()
        self._play: asyncio.Event | None = None
        self._target = start_at + 1
        self.written = start_at + 1  # samples written so far
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._run)
        self.error: BaseException | None = None
        self._server: Server | None = None

    def watched(self) -> bool:
        """Whether a client has a subscription with a monitored item (read in its loop)."""
        server = self._server
        if server is None or not self.ready.is_set():
            return False

        async def look() -> bool:
            subscriptions = server.iserver.subscription_service.subscriptions.values()
            return any(s.monitored_item_srv._monitored_items for s in subscriptions)

        try:
            return asyncio.run_coroutine_threadsafe(look(), self.loop).result(timeout=5)
        except (TimeoutError, RuntimeError):  # the loop is closing
            return False

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        try:
            self.loop.run_until_complete(self._main())
        finally:  # sessions of clients that were killed leave tasks behind: end them
            pending = asyncio.all_tasks(self.loop)
            for task in pending:
                task.cancel()
            self.loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
            self.loop.close()

    def start(self) -> None:
        """Start serving (in a thread); raise when the server fails or hangs while starting.

        The wait is on the server, not a clock: loading the official nodesets took over 30 s
        on a loaded 2-core host (two collector tests failed on a fixed 30 s); only a start
        that hangs reaches :data:`START_BOUND_S`.
        """
        self._thread.start()
        deadline = time.monotonic() + START_BOUND_S
        while not self.ready.wait(0.5):
            if not self._thread.is_alive() or time.monotonic() > deadline:
                break
        if not self.ready.is_set() or self.error is not None:
            raise RuntimeError(f"OPC UA server did not start: {self.error!r}")

    def play(self, until: int | None = None) -> None:
        """Write the samples up to ``until`` (all by default), then wait for more."""
        assert self._play is not None
        target = len(self.trace) if until is None else until
        self.loop.call_soon_threadsafe(self._advance, target)

    def _advance(self, target: int) -> None:
        assert self._play is not None
        self._target = max(self._target, target)
        self._play.set()

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        if self._stop is not None:
            self.loop.call_soon_threadsafe(self._halt)
        self._thread.join(30)

    def _halt(self) -> None:
        assert self._stop is not None and self._play is not None
        self._stop.set()
        self._play.set()

    async def _main(self) -> None:
        try:
            await self._serve()
        except BaseException as err:  # reported by start()
            self.error = err
            self.ready.set()
            raise

    async def _serve(self) -> None:
        self._play, self._stop = asyncio.Event(), asyncio.Event()
        server = self._server = Server()
        await server.init()
        server.set_endpoint(self.url)
        server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        first = self.trace[self.start_at]
        nodes = await self.space(server, first)
        async with server:
            await self._write(nodes, None, first, self.start_at)
            self.ready.set()
            for i, sample in enumerate(self.trace[self.start_at + 1 :], start=self.start_at + 1):
                while i >= self._target and not self._stop.is_set():
                    self._play.clear()
                    await self._play.wait()
                if self._stop.is_set():
                    break
                await self._write(nodes, self.trace[i - 1], sample, i)
                self.written = i + 1
                if i % 20 == 0:
                    await asyncio.sleep(0.004)
            self.done.set()
            await self._stop.wait()

    @staticmethod
    async def _write(
        nodes: Nodes,
        before: TraceSample | None,
        sample: TraceSample,
        i: int,
    ) -> None:
        stamp = _BASE + dt.timedelta(milliseconds=i)
        values = {
            "execution": 2 if sample.execution == "ACTIVE" else 0,
            "program": PROGRAM,
            "part_count": sample.part_count,
            "tool_number": sample.tool_number,
            "block": f"N{sample.block} G01",
            "spindle_speed_rpm": sample.spindle_speed_rpm,
            "feed_rate_mm_min": sample.feed_rate_mm_min,
            "spindle_load": sample.spindle_load,
        }
        old = (
            None
            if before is None
            else {
                "execution": 2 if before.execution == "ACTIVE" else 0,
                "program": PROGRAM,
                "part_count": before.part_count,
                "tool_number": before.tool_number,
                "block": f"N{before.block} G01",
                "spindle_speed_rpm": before.spindle_speed_rpm,
                "feed_rate_mm_min": before.feed_rate_mm_min,
                "spindle_load": None,
            }
        )
        for item, value in values.items():
            if old is not None and old[item] == value:
                continue
            node, kind, array = nodes[item]
            # an array: the block being run, then (here: none) the blocks after it
            written: object = [value, "", ""] if array else value
            await node.write_value(
                ua.DataValue(
                    ua.Variant(written, kind), SourceTimestamp=stamp, ServerTimestamp=stamp
                )
            )
