"""The console blocks of the docs as bash scripts: what ``tests/api/test_docs.py`` runs.

A console block is a fenced block opened with three backticks and ``console``. In it a line
starting with ``$ `` is a command (a line ending in a backslash continues on the next line);
the lines up to the next command are its expected output: each non-empty one that is not
``...`` must appear in what the command printed (stdout and stderr together), and a line
ending in ``...`` must begin a printed line. A block preceded by the HTML comment
``<!-- docs-test: skip REASON -->`` is not run (the README's install commands are not in a
console block at all: see ``tests/api/test_docs.py``).
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

from api.cli.virtual import DEFAULT_PORTS

FENCE = re.compile(r"^```console\s*$")
SKIP = re.compile(r"<!--\s*docs-test:\s*skip\b(.*?)-->")
PORT = 8000  # the REST service's port the docs write; the test puts a free one in its place
#: Any other port a page serves on (``--port 5001``): each gets a free one too, since two
#: pages run at once, or a server another test left, would otherwise meet on it.
SERVED = re.compile(r"--port (\d+)\b")
#: A virtual machine started on its protocol's default port (no ``--port``: 5000 for
#: MTConnect, 4840 for OPC UA, as try-a-machine.md shows it) is given ``--port`` in the test.
VIRTUAL = re.compile(r"\brcb virtual serve\b")
PROTOCOL = re.compile(r"--protocol (\w+)")


@dataclass(frozen=True)
class Command:
    """One ``$ `` command of a page, where it is written and what it should print."""

    page: str
    line: int
    text: str
    expected: tuple[str, ...]

    def expects_in(self, output: str) -> list[str]:
        """The expected lines missing from ``output`` (empty: all there)."""
        printed = [line.rstrip() for line in output.splitlines()]
        missing = []
        for want in self.expected:
            if want.endswith("..."):
                head = want[:-3]
                if not any(line.strip().startswith(head.strip()) for line in printed):
                    missing.append(want)
            elif not any(want.strip() in line for line in printed):
                missing.append(want)
        return missing


def commands(page: Path, root: Path) -> list[Command]:
    """Every command of ``page``'s console blocks, in order."""
    name = page.relative_to(root).as_posix()
    lines = page.read_text(encoding="utf-8").splitlines()
    found: list[Command] = []
    inside = skipped = False
    current: list[str] = []
    start = 0
    expected: list[str] = []

    def close() -> None:
        if current:
            found.append(Command(name, start, "\n".join(current), tuple(expected)))

    for number, line in enumerate(lines, 1):
        if not inside:
            if FENCE.match(line):
                inside = True
                previous = next((p for p in reversed(lines[: number - 1]) if p.strip()), "")
                skipped = bool(SKIP.search(previous))
                current, expected = [], []
            continue
        if line.startswith("```"):
            if not skipped:
                close()
            inside, current, expected = False, [], []
            continue
        if skipped:
            continue
        if current and current[-1].endswith("\\") and not expected:
            current.append(line)
        elif line.startswith("$ "):
            close()
            current, expected, start = [line[2:]], [], number
        elif current and line.strip() and line.strip() != "...":
            expected.append(line.rstrip())
    return found


def written_ports(cmds: list[Command]) -> list[int]:
    """The ports ``cmds`` write: the service's 8000, every ``--port N`` and a virtual machine's
    default (:func:`_default_port`), in order."""
    found = [PORT]
    for c in cmds:
        default = _default_port(c.text)
        found += [int(n) for n in SERVED.findall(c.text)] + ([default] if default else [])
    return list(dict.fromkeys(found))


def _default_port(text: str) -> int | None:
    """The port a ``rcb virtual serve`` with no ``--port`` serves on (None: not one)."""
    protocol = PROTOCOL.search(text)
    if not VIRTUAL.search(text) or SERVED.search(text) or protocol is None:
        return None
    return DEFAULT_PORTS.get(protocol.group(1))  # a StrEnum key is its text; a typo: None


def _with_ports(text: str, ports: dict[int, int]) -> str:
    default = _default_port(text)
    if default is not None:
        text = VIRTUAL.sub(f"rcb virtual serve --port {default}", text, count=1)
    for written, given in ports.items():
        text = re.sub(rf"(?<=:){written}\b|(?<=--port ){written}\b", str(given), text)
    return text


def script(cmds: list[Command], ports: dict[int, int], outputs: Path) -> str:
    """A bash script running ``cmds`` in one shell, each one's output to its own file.

    Each port the page writes is replaced by the one ``ports`` gives it (``written_ports``).

    Variables and background jobs carry from one command to the next, as in a terminal. The
    script stops at the first command that fails, leaving its index and status in
    ``outputs/failed``; ``outputs/seconds`` holds each command's start and end.
    """
    lines = ["set -u", "set -o pipefail"]
    for index, cmd in enumerate(cmds):
        text = _with_ports(cmd.text, ports)
        out = shlex.quote(str(outputs / f"{index}.out"))
        failed = shlex.quote(str(outputs / "failed"))
        times = shlex.quote(str(outputs / "seconds"))
        if _in_background(text):
            lines.append(f"{text.rstrip()[:-1].rstrip()} > {out} 2>&1 &")
            continue
        lines.append(f"start=$EPOCHREALTIME; {{\n{text}\n}} > {out} 2>&1")
        lines.append(f"status=$?; echo {index} $start $EPOCHREALTIME >> {times}")
        lines.append(f"if [ $status -ne 0 ]; then echo {index} $status > {failed}; exit 1; fi")
    return "\n".join(lines) + "\n"


def hung(cmds: list[Command], outputs: Path, seconds: float) -> str:
    """What a script that did not end in ``seconds`` was running, with its and its servers' output.

    The running command is the first one that neither finished (``outputs/seconds``) nor runs
    in the background; each background command's output is shown too, since a server or a
    machine that died is what a foreground wait most often waits for.
    """
    times = outputs / "seconds"
    done = (
        {int(line.split()[0]) for line in times.read_text().splitlines()}
        if times.exists()
        else set()
    )
    background = {i for i, c in enumerate(cmds) if _in_background(c.text)}
    running = next((i for i in range(len(cmds)) if i not in done | background), None)
    where = (
        f"{cmds[running].page}:{cmds[running].line}: $ {cmds[running].text}"
        if running is not None
        else "?"
    )
    lines = [f"the page did not end in {seconds} s; running: {where}"]
    for index in sorted(background | ({running} if running is not None else set())):
        file = outputs / f"{index}.out"
        tail = file.read_text(errors="replace")[-1500:] if file.exists() else "(no output)"
        lines.append(f"--- {cmds[index].line}: $ {cmds[index].text}\n{tail}")
    return "\n".join(lines)


def _in_background(text: str) -> bool:
    return text.rstrip().endswith("&") and not text.rstrip().endswith("&&")
