"""``rcb collect --config collector.toml``: a machine's spindle signals → part reports.

Runs until interrupted (SIGINT/SIGTERM stop it cleanly; a ``kill -9`` loses nothing: see
:mod:`api.collect.queue`), or with ``--parts N`` until N parts are sent; it logs its start, each
part and its stop with the run's counts. ``--status`` prints the queue's state and exits.
asyncua and httpx are imported inside the command, so other ``rcb`` commands do not load them.
"""

from __future__ import annotations

import asyncio
import json
import logging
import signal
import sys
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from api.cli.common import errors

if TYPE_CHECKING:
    from api.collect.config import CollectorConfig
    from api.collect.queue import Queue

_STATUS_ROWS = 10


def collect(
    config: Annotated[
        Path, typer.Option("--config", metavar="collector.toml", help="The collector's file.")
    ],
    status: Annotated[
        bool, typer.Option("--status", help="Print the queue's state and exit.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="--status as JSON.")] = False,
    parts: Annotated[
        int | None,
        typer.Option(
            "--parts",
            min=1,
            help="Stop once this many parts are sent in this run (default: at SIGTERM/SIGINT).",
        ),
    ] = None,
) -> None:
    """Read one machine's spindle load over OPC UA or MTConnect and report each part."""
    from api.collect.config import load_config
    from api.collect.queue import open_queue

    with errors():
        settings = load_config(config)
        if not status:
            settings.api_key()  # refuse at once when the key's variable is unset
    queue = open_queue(settings.queue_path)
    try:
        if status:
            _status(queue.status(_STATUS_ROWS), as_json)
            return
        with errors():  # a node or a file refused at start: one line, exit 2
            _run(settings, queue, parts)
    finally:
        queue.close()


def _echo(line: str) -> None:
    """One line of --status, wrapped to 80 columns (a log or a pipe)."""
    typer.echo(textwrap.fill(line, width=80, subsequent_indent="      "))


def _status(state: dict[str, object], as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(state, indent=2))
        return
    _echo(
        f"pending {state['pending']}  sent {state['sent']}  rejected {state['rejected']}  "
        f"skipped parts {state['skipped_parts']}  gaps {state['gaps']}"
    )
    point = state["checkpoint"]
    if isinstance(point, dict):
        _echo(f"checkpoint: {point['source']} instance {point['instance']} next {point['next']}")
    for row in state["recent"]:  # type: ignore[attr-defined]
        _echo(
            f"  part {row['part_count']} ({row['program']}): {row['state']}"
            f" (HTTP {row['status']}, {row['tries']} tries)"
        )
    for row in state["recent_skipped"]:  # type: ignore[attr-defined]
        counts = ", ".join(str(n) for n in row["part_counts"])
        _echo(f"  NOT reported: parts {counts}: {row['reason']}")
    for row in state["recent_gaps"]:  # type: ignore[attr-defined]
        _echo(f"  GAP: sequences {row['first']}..{row['last']}: {row['reason']}")


def _run(settings: CollectorConfig, queue: Queue, parts: int | None) -> None:
    from api.collect.runner import log, run

    logging.basicConfig(
        stream=sys.stderr, level=logging.INFO, format="%(asctime)s rcb collect: %(message)s"
    )
    for noisy in ("asyncua", "httpx", "httpcore"):
        logging.getLogger(noisy).setLevel(logging.WARNING)

    async def main() -> str:
        stop, caught = asyncio.Event(), list[str]()

        def on_signal(sig: signal.Signals) -> None:
            caught.append(sig.name)
            stop.set()

        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, on_signal, sig)
        counting = None
        if parts is not None:
            counting = asyncio.create_task(_until_sent(queue, before["sent"] + parts, stop))
        await run(settings, queue, stop)
        if counting is not None:
            await counting
        if caught:
            return caught[0]
        return f"{parts} parts sent" if parts is not None else "the reader ended"

    before, why = queue.status(0), "an error"
    try:
        why = asyncio.run(main())
    finally:
        after = queue.status(0)
        log.info(
            "stopped (%s): this run queued %d parts, sent %d, rejected %d, skipped %d, gaps %d; "
            "%d pending in the queue (rcb collect --status)",
            why,
            _total(after) - _total(before),
            after["sent"] - before["sent"],
            after["rejected"] - before["rejected"],
            after["skipped_parts"] - before["skipped_parts"],
            after["gaps"] - before["gaps"],
            after["pending"],
        )


async def _until_sent(queue: Queue, sent: int, stop: asyncio.Event) -> None:
    """Set ``stop`` once the queue counts ``sent`` reports sent (or when it is set)."""
    while not stop.is_set():
        if queue.status(0)["sent"] >= sent:
            stop.set()
            return
        try:
            await asyncio.wait_for(stop.wait(), timeout=0.2)
        except TimeoutError:
            pass


def _total(state: dict[str, Any]) -> int:
    """Reports in the queue, whatever their state."""
    return int(state["pending"] + state["sent"] + state["rejected"])
