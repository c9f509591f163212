"""CPU accounting from /proc: processes, the host, connections per process, a quiet host."""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from benchmarks.api_load.config import CLK_TCK


def _stat_fields(pid: int) -> list[str] | None:
    try:
        raw = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return raw.rpartition(")")[2].split()  # [state, ppid, ..., utime (11), stime (12), ...]


def process_cpu_s(pid: int) -> float | None:
    """User + system CPU seconds of one process (None if it is gone)."""
    fields = _stat_fields(pid)
    return None if fields is None else (int(fields[11]) + int(fields[12])) / CLK_TCK


def descendants(pid: int) -> list[int]:
    """Every live descendant of ``pid`` (children, grandchildren, ...)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            fields = _stat_fields(int(entry.name))
            if fields is not None:
                children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return sorted(found)


def host_cpu_s() -> tuple[float, float]:
    """(busy, total) CPU seconds of the whole host since boot, from /proc/stat."""
    values = [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    total = sum(values[:8])  # user nice system idle iowait irq softirq steal
    return (total - values[3] - values[4]) / CLK_TCK, total / CLK_TCK


def connections_per_process(pids: Sequence[int], port: int) -> list[int]:
    """Established TCP connections to local ``port`` held by each of ``pids`` (IPv4)."""
    inodes: set[str] = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        cols = line.split()
        if cols[3] == "01" and int(cols[1].rpartition(":")[2], 16) == port:
            inodes.add(cols[9])
    counts = []
    for pid in pids:
        n = 0
        try:
            for fd in Path(f"/proc/{pid}/fd").iterdir():
                try:
                    target = os.readlink(fd)
                except OSError:
                    continue
                if target.startswith("socket:[") and target[8:-1] in inodes:
                    n += 1
        except OSError:
            pass
        counts.append(n)
    return counts


def wait_for_quiet(max_wait_s: float, busy_below: float = 0.25) -> float:
    """Wait up to ``max_wait_s`` until the host is < ``busy_below`` busy over 2 s; the last
    busy fraction seen."""
    deadline = time.monotonic() + max_wait_s
    while True:
        b0, t0 = host_cpu_s()
        time.sleep(2.0)
        b1, t1 = host_cpu_s()
        busy = (b1 - b0) / max(t1 - t0, 1e-9)
        if busy < busy_below or time.monotonic() >= deadline:
            return busy


def self_cpu_s() -> float:
    """CPU seconds of this process (all its threads)."""
    return time.process_time()


@dataclass
class CpuSnapshot:
    """CPU counters at one instant."""

    server: dict[int, float]
    postgres: dict[int, float]
    client: float
    host_busy: float
    host_total: float
    others: dict[int, float]  # every other process: not this script's tree nor its backends
