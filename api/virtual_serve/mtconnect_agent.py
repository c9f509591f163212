"""An MTConnect agent on 127.0.0.1 (stdlib ``http.server``) playing a virtual lathe's trace.

``rcb virtual serve --protocol mtconnect`` serves it (:mod:`api.virtual_serve.run`); the
collector's tests serve it in a thread (:func:`serve`).

The trace's samples become observations with sequence numbers as an agent makes them: a data
item gets an observation when its value changes (the load at every sample). ``release(n)``
makes the first ``n`` observations available (``play`` releases them at a rate in a thread);
the agent keeps the last ``buffer_size`` of them, so a reader that falls behind meets a buffer
wrap: ``/sample?from=`` older than ``firstSequence`` is an MTConnectError ``OUT_OF_RANGE``.
Documents are MTConnectStreams 2.0, valid against the standard's schema
(the standard's XSD named by ``RCB_MTCONNECT_XSD``, checked in
``tests/api/test_collect_mtconnect.py``).
``/probe`` is the device model, as an agent has it: the spindle is the ``Rotary`` C in spindle
mode, the path's feed rate is in MILLIMETER/SECOND as the Standard has it (the agent streams the
trace's mm/min / 60), beside a feed-rate override in PERCENT.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import parse_qs, urlparse
from xml.sax.saxutils import escape

from supervisor.virtual.trace import TraceSample

NS = "urn:mtconnect.org:MTConnectStreams:2.0"
#: item → (component, componentId, element, dataItemId, category)
ITEMS = {
    "execution": ("Path", "path1", "Execution", "exec", "Events"),
    "program": ("Path", "path1", "Program", "pgm", "Events"),
    "part_count": ("Path", "path1", "PartCount", "pc", "Events"),
    "tool_number": ("Path", "path1", "ToolNumber", "tool", "Events"),
    "block": ("Path", "path1", "Block", "blk", "Events"),
    "feed_rate_mm_min": ("Path", "path1", "PathFeedrate", "Frt", "Samples"),
    "spindle_speed_rpm": ("Rotary", "c1", "RotaryVelocity", "Srpm", "Samples"),
    "spindle_load": ("Rotary", "c1", "Load", "Sload", "Samples"),
}
PROGRAM = "O1001"
DEVICES_NS = "urn:mtconnect.org:MTConnectDevices:2.0"
#: The device model (``/probe``): the ids of ITEMS, in their components. The load has no units
#: here: the trace's is a voltage (Ivester & Heigel's sensor), which no MTConnect LOAD unit is.
DEVICE = """<Device id="lathe" name="lathe" uuid="lathe-1">
<DataItems><DataItem category="EVENT" id="avail" type="AVAILABILITY"/></DataItems>
<Components><Axes id="ax" name="Axes"><Components><Rotary id="c1" name="C"><DataItems>
<DataItem category="SAMPLE" id="Srpm" type="ROTARY_VELOCITY" subType="ACTUAL"
 units="REVOLUTION/MINUTE" nativeUnits="REVOLUTION/MINUTE"/>
<DataItem category="SAMPLE" id="Sload" type="LOAD"/>
<DataItem category="EVENT" id="Smode" type="ROTARY_MODE">
<Constraints><Value>SPINDLE</Value></Constraints></DataItem>
</DataItems></Rotary></Components></Axes>
<Controller id="cont" name="controller"><Components><Path id="path1" name="path"><DataItems>
<DataItem category="EVENT" id="exec" type="EXECUTION"/>
<DataItem category="EVENT" id="pgm" type="PROGRAM"/>
<DataItem category="EVENT" id="pc" type="PART_COUNT"/>
<DataItem category="EVENT" id="tool" type="TOOL_NUMBER"/>
<DataItem category="EVENT" id="blk" type="BLOCK"/>
<DataItem category="SAMPLE" id="Fovr" type="PATH_FEEDRATE" subType="OVERRIDE" units="PERCENT"/>
<DataItem category="SAMPLE" id="Frt" type="PATH_FEEDRATE" subType="ACTUAL"
 units="MILLIMETER/SECOND" nativeUnits="MILLIMETER/MINUTE"/>
</DataItems></Path></Components></Controller></Components></Device>"""


def mm_s_text(feed_rate_mm_min: float) -> str:
    """The mm/s an agent streams for ``feed_rate_mm_min``: the float whose × 60 is it exactly.

    (A collector reading it × 60 then reports the trace's own value, which the MES posts.)
    """
    x = feed_rate_mm_min / 60.0
    for step in (0, 1, -1, 2, -2, 3, -3):
        candidate = x
        for _ in range(abs(step)):
            candidate = math.nextafter(candidate, math.inf if step > 0 else -math.inf)
        if candidate * 60.0 == feed_rate_mm_min:
            return repr(candidate)
    return repr(x)  # none within 3 ulp (not met in practice): the nearest, off by round-off


@dataclass(frozen=True)
class Obs:
    """One observation: its sequence number, signal, text and timestamp."""

    sequence: int
    item: str
    text: str
    timestamp: str


def observations(trace: list[TraceSample]) -> list[Obs]:
    """The agent's observations of a trace, in sequence order (changes only; load always)."""
    return observations_per_sample(trace)[0]


def observations_per_sample(trace: list[TraceSample]) -> tuple[list[Obs], list[int]]:
    """The observations of a trace, and how many there are once each sample is made."""
    found: list[Obs] = []
    made: list[int] = []
    last: dict[str, str] = {}
    for i, sample in enumerate(trace):
        stamp = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(1_700_000_000 + i // 100))
        stamp += f".{(i % 100) * 10000:06d}Z"
        values = {
            "execution": sample.execution,
            "program": PROGRAM,
            "part_count": str(sample.part_count),
            "tool_number": str(sample.tool_number),
            "block": f"N{sample.block} G01",
            "feed_rate_mm_min": mm_s_text(sample.feed_rate_mm_min),
            "spindle_speed_rpm": repr(sample.spindle_speed_rpm),
            "spindle_load": repr(sample.spindle_load),
        }
        for item, text in values.items():
            if item == "spindle_load" or last.get(item) != text:
                found.append(Obs(len(found) + 1, item, text, stamp))
                last[item] = text
        made.append(len(found))
    return found, made


class Agent:
    """The agent's state: the observations, how many are released, the buffer size."""

    def __init__(self, obs: list[Obs], buffer_size: int, instance_id: int = 1700000000) -> None:
        self.obs, self.buffer_size, self.instance_id = obs, buffer_size, instance_id
        self.released = 0
        self.read_to = 0  # the highest sequence a reader has been sent
        self.lock = threading.Lock()
        self._player: threading.Thread | None = None
        self._stop = threading.Event()

    def release(self, n: int) -> None:
        """Make the first ``n`` observations available (never fewer than before)."""
        with self.lock:
            self.released = max(self.released, min(n, len(self.obs)))

    def play(self, per_second: float) -> None:
        """Release the rest at ``per_second`` observations per second, in a thread."""

        def run() -> None:
            step = max(1, int(per_second / 50))
            while not self._stop.is_set() and self.released < len(self.obs):
                self.release(self.released + step)
                time.sleep(step / per_second)

        self._player = threading.Thread(target=run, daemon=True)
        self._player.start()

    def release_in_step(self, n: int, step: int, timeout_s: float = 30.0) -> None:
        """Release up to ``n``, ``step`` at a time, each once a reader has read what is out."""
        for upto in range(self.released + step, n + step, step):
            self.release(min(upto, n))
            deadline = time.monotonic() + timeout_s
            while self.read_to < self.released:
                if time.monotonic() > deadline:
                    raise TimeoutError(f"no reader past sequence {self.read_to}")
                time.sleep(0.005)

    def stop(self) -> None:
        """Stop :meth:`play`."""
        self._stop.set()

    def first(self) -> int:
        """The oldest sequence in the buffer (``firstSequence``)."""
        return max(1, self.released - self.buffer_size + 1)

    def header(self, next_sequence: int) -> str:
        """The ``<Header>`` of a streams document."""
        return (
            f'<Header creationTime="2026-11-25T00:00:00Z" sender="rcb-virtual" '
            f'instanceId="{self.instance_id}" version="2.0.0.0" '
            f'bufferSize="{self.buffer_size}" deviceModelChangeTime="2026-11-25T00:00:00Z" '
            f'nextSequence="{next_sequence}" '
            f'firstSequence="{self.first()}" lastSequence="{max(self.released, 1)}"/>'
        )

    def document(self, chosen: list[Obs], next_sequence: int) -> str:
        """An MTConnectStreams document of ``chosen``."""
        components: dict[tuple[str, str], dict[str, list[str]]] = {}
        for o in chosen:
            component, cid, element, did, category = ITEMS[o.item]
            lines = components.setdefault((component, cid), {}).setdefault(category, [])
            lines.append(
                f'<{element} dataItemId="{did}" timestamp="{o.timestamp}" '
                f'sequence="{o.sequence}">{escape(o.text)}</{element}>'
            )
        streams = []
        for (component, cid), categories in components.items():
            inner = "".join(
                f"<{c}>{''.join(categories[c])}</{c}>"
                for c in ("Samples", "Events")
                if c in categories
            )
            streams.append(
                f'<ComponentStream component="{component}" componentId="{cid}">{inner}'
                "</ComponentStream>"
            )
        device = '<DeviceStream name="lathe" uuid="lathe-1">' + "".join(streams) + "</DeviceStream>"
        return (
            f'<?xml version="1.0" encoding="UTF-8"?>\n<MTConnectStreams xmlns="{NS}">'
            f"{self.header(next_sequence)}<Streams>{device}</Streams></MTConnectStreams>"
        )

    def probe(self) -> str:
        """The ``/probe`` document: the device model."""
        return (
            f'<?xml version="1.0" encoding="UTF-8"?>\n<MTConnectDevices xmlns="{DEVICES_NS}">'
            f'<Header creationTime="2026-11-25T00:00:00Z" sender="rcb-virtual" '
            f'instanceId="{self.instance_id}" version="2.0.0.0" bufferSize="{self.buffer_size}" '
            f'assetBufferSize="0" assetCount="0" deviceModelChangeTime="2026-11-25T00:00:00Z"/>'
            f"<Devices>{DEVICE}</Devices></MTConnectDevices>"
        )

    def current(self) -> str:
        """The ``/current`` document: the latest observation of every data item."""
        with self.lock:
            latest: dict[str, Obs] = {}
            for o in self.obs[: self.released]:
                latest[o.item] = o
            return self.document(
                sorted(latest.values(), key=lambda o: o.sequence), self.released + 1
            )

    def sample(self, start: int, count: int) -> tuple[int, str]:
        """The ``/sample?from=start&count=count`` answer: HTTP status and document."""
        with self.lock:
            if start < self.first() or start > self.released + 1:
                return 400, self.error("OUT_OF_RANGE", f"'from' must be >= {self.first()}")
            chosen = self.obs[start - 1 : min(start - 1 + count, self.released)]
            self.read_to = max(self.read_to, start - 1 + len(chosen))
            return 200, self.document(chosen, start + len(chosen))

    def error(self, code: str, text: str) -> str:
        """An MTConnectError document."""
        return (
            '<?xml version="1.0" encoding="UTF-8"?>\n'
            '<MTConnectError xmlns="urn:mtconnect.org:MTConnectError:2.0">'
            f'<Header creationTime="2026-11-25T00:00:00Z" sender="rcb-virtual" '
            f'instanceId="{self.instance_id}" version="2.0.0.0" bufferSize="{self.buffer_size}"/>'
            f'<Errors><Error errorCode="{code}">{escape(text)}</Error></Errors></MTConnectError>'
        )


def serve(
    agent: Agent, port: int = 0, on_sample: Callable[[], None] | None = None
) -> tuple[ThreadingHTTPServer, str]:
    """Serve ``agent`` on 127.0.0.1 in a thread; the server and its base URL (with the device).

    ``port`` 0 takes a free port. ``on_sample`` is called at every ``/sample`` request (before
    it is answered): ``rcb virtual serve`` starts making parts when a reader first asks.
    """

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args: Any) -> None:
            pass

        def do_GET(self) -> None:
            url = urlparse(self.path)
            query = {k: v[0] for k, v in parse_qs(url.query).items()}
            if url.path.endswith("/probe"):
                status, body = 200, agent.probe()
            elif url.path.endswith("/current"):
                status, body = 200, agent.current()
            elif url.path.endswith("/sample"):
                if on_sample is not None:
                    on_sample()
                status, body = agent.sample(int(query.get("from", 1)), int(query.get("count", 100)))
            else:
                status, body = 404, agent.error("INVALID_REQUEST", url.path)
            data = body.encode()
            self.send_response(status)
            self.send_header("Content-Type", "application/xml")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

    server = ThreadingHTTPServer(("127.0.0.1", port), Handler)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/lathe"
