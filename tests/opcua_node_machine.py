"""``tests/opcua_node_server.js`` (node-opcua) as a process on 127.0.0.1 playing a trace."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import threading
import time
from pathlib import Path

from api.virtual_serve.opcua_machine import PROGRAM
from supervisor.virtual.trace import TraceSample

from live import kill_group

SCRIPT = Path(__file__).with_name("opcua_node_server.js")


class NodeOpcUaMachine:
    """``start()`` serves the trace's first sample; ``play()`` writes the rest; ``stop()``."""

    def __init__(self, trace: list[TraceSample], port: int, npm: Path, folder: Path) -> None:
        self.trace, self.port, self.npm, self.folder = trace, port, npm, folder
        self.url = f"opc.tcp://127.0.0.1:{port}/rcb"
        self.process: subprocess.Popen[str] | None = None
        self.lines: queue.Queue[str] = queue.Queue()

    def start(self, timeout_s: float = 60.0) -> None:
        samples = [
            [s.part_count, s.execution, s.block, s.tool_number]
            + [s.spindle_load, s.spindle_speed_rpm, s.feed_rate_mm_min]
            for s in self.trace
        ]
        path = self.folder / "trace.json"
        path.write_text(json.dumps({"program": PROGRAM, "samples": samples}), encoding="utf-8")
        env = {**os.environ, "NODE_PATH": str(self.npm / "node_modules")}
        self.process = subprocess.Popen(
            ["node", str(SCRIPT), str(path), str(self.port), str(self.folder / "pki")],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=(self.folder / "node-opcua.log").open("w"),
            text=True,
            env=env,
            start_new_session=True,
        )
        stdout = self.process.stdout
        assert stdout is not None
        threading.Thread(target=lambda: [self.lines.put(x) for x in stdout], daemon=True).start()
        self._expect("ready", timeout_s)

    def _expect(self, word: str, timeout_s: float) -> None:
        """Wait for a line starting with ``word`` (node-opcua prints its warnings there too)."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                log = (self.folder / "node-opcua.log").read_text()[-2000:]
                why = f"node-opcua server: no {word!r} in {timeout_s} s: {log}"
                raise AssertionError(why) from None
            if line.startswith(word):
                return

    def play(self) -> None:
        assert self.process is not None and self.process.stdin is not None
        self.process.stdin.write("play\n")
        self.process.stdin.flush()

    def stop(self) -> None:
        if self.process is None:
            return
        try:
            if self.process.stdin is not None:
                self.process.stdin.close()  # the server shuts down when stdin closes
            self.process.wait(10)
        except (subprocess.TimeoutExpired, OSError):
            kill_group(self.process)
        self.process = None
