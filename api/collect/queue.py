"""The collector's durable local queue: one SQLite file per machine (stdlib ``sqlite3``).

It holds, in the order the parts were made, every part report (with its Idempotency-Key, unique)
until the REST service has stored it; every part not reported and why (a buffer wrap, a join
mid-part ...); the gaps seen; and the read checkpoint (the MTConnect agent's instance and the
sequence after the last part boundary, with the segmenter's state there). A part and the
checkpoint past it commit in one transaction, so a ``kill -9`` at any moment either keeps both
(the restart reads on from after the part) or neither (the restart reads the part again and
queues it once: the key is unique). WAL mode, ``synchronous=FULL``.
"""

from __future__ import annotations

import json
import sqlite3
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

_SCHEMA = """
CREATE TABLE IF NOT EXISTS reports (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    idempotency_key TEXT NOT NULL UNIQUE,
    part_count INTEGER NOT NULL,
    program TEXT NOT NULL,
    body TEXT NOT NULL,
    state TEXT NOT NULL DEFAULT 'pending',   -- pending, sent, rejected
    attempts INTEGER NOT NULL DEFAULT 0,
    status INTEGER,
    answer TEXT,
    queued_at REAL NOT NULL,
    done_at REAL
);
CREATE INDEX IF NOT EXISTS reports_pending ON reports (state, id);
CREATE TABLE IF NOT EXISTS skipped (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    part_counts TEXT NOT NULL,
    program TEXT NOT NULL,
    reason TEXT NOT NULL,
    at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS gaps (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    first_lost INTEGER,
    last_lost INTEGER,
    reason TEXT NOT NULL,
    at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS checkpoint (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    source TEXT NOT NULL,
    instance TEXT NOT NULL,
    next_sequence INTEGER NOT NULL,
    state TEXT NOT NULL,
    at REAL NOT NULL
);
"""


@dataclass(frozen=True)
class Checkpoint:
    """Where reading resumes: the agent instance, the next sequence, the segmenter's state."""

    source: str
    instance: str
    next_sequence: int
    state: dict[str, Any]


@dataclass(frozen=True)
class Pending:
    """The oldest report not yet stored by the service."""

    id: int
    idempotency_key: str
    part_count: int
    body: bytes
    attempts: int


class Queue:
    """The queue file; open it with :func:`open_queue`."""

    def __init__(self, connection: sqlite3.Connection) -> None:
        self.db = connection

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield self.db
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    def close(self) -> None:
        """Close the file."""
        self.db.close()

    def checkpoint(self) -> Checkpoint | None:
        """The checkpoint, or None before the first."""
        row = self.db.execute(
            "SELECT source, instance, next_sequence, state FROM checkpoint WHERE id = 1"
        ).fetchone()
        if row is None:
            return None
        return Checkpoint(row[0], row[1], int(row[2]), json.loads(row[3]))

    def record(
        self,
        checkpoint: Checkpoint | None,
        *,
        report: tuple[str, int, str, bytes] | None = None,
        skipped: tuple[tuple[int, ...], str, str] | None = None,
        gap: tuple[int | None, int | None, str] | None = None,
    ) -> bool:
        """Queue a report, a skip or a gap and move the checkpoint, in one transaction.

        ``report`` is ``(key, part_count, program, body)``. False when its key was queued before.
        """
        now = time.time()
        added = True
        with self._write() as db:
            if report is not None:
                key, count, program, body = report
                cursor = db.execute(
                    "INSERT OR IGNORE INTO reports (idempotency_key, part_count, program, body,"
                    " queued_at) VALUES (?, ?, ?, ?, ?)",
                    (key, count, program, body.decode("utf-8"), now),
                )
                added = cursor.rowcount == 1
            if skipped is not None:
                counts, program, reason = skipped
                db.execute(
                    "INSERT INTO skipped (part_counts, program, reason, at) VALUES (?, ?, ?, ?)",
                    (json.dumps(list(counts)), program, reason, now),
                )
            if gap is not None:
                db.execute(
                    "INSERT INTO gaps (first_lost, last_lost, reason, at) VALUES (?, ?, ?, ?)",
                    (*gap, now),
                )
            if checkpoint is not None:
                db.execute(
                    "INSERT INTO checkpoint (id, source, instance, next_sequence, state, at)"
                    " VALUES (1, ?, ?, ?, ?, ?) ON CONFLICT (id) DO UPDATE SET"
                    " source = excluded.source, instance = excluded.instance,"
                    " next_sequence = excluded.next_sequence, state = excluded.state,"
                    " at = excluded.at",
                    (
                        checkpoint.source,
                        checkpoint.instance,
                        checkpoint.next_sequence,
                        json.dumps(checkpoint.state, sort_keys=True),
                        now,
                    ),
                )
        return added

    def next_pending(self) -> Pending | None:
        """The oldest pending report."""
        row = self.db.execute(
            "SELECT id, idempotency_key, part_count, body, attempts FROM reports"
            " WHERE state = 'pending' ORDER BY id LIMIT 1"
        ).fetchone()
        if row is None:
            return None
        return Pending(int(row[0]), row[1], int(row[2]), row[3].encode("utf-8"), int(row[4]))

    def attempted(self, report_id: int) -> None:
        """Count one more attempt."""
        with self._write() as db:
            db.execute("UPDATE reports SET attempts = attempts + 1 WHERE id = ?", (report_id,))

    def settle(self, report_id: int, state: str, status: int, answer: Mapping[str, Any]) -> None:
        """Mark a report ``sent`` (stored by the service) or ``rejected`` (refused: 4xx)."""
        with self._write() as db:
            db.execute(
                "UPDATE reports SET state = ?, status = ?, answer = ?, done_at = ? WHERE id = ?",
                (state, status, json.dumps(answer, sort_keys=True), time.time(), report_id),
            )

    def status(self, last: int = 10) -> dict[str, Any]:
        """Counts by state, the checkpoint, and the last ``last`` reports, skips and gaps."""
        counts = dict(
            self.db.execute("SELECT state, count(*) FROM reports GROUP BY state").fetchall()
        )
        recent = self.db.execute(
            "SELECT part_count, program, state, status, attempts FROM reports"
            " ORDER BY id DESC LIMIT ?",
            (last,),
        ).fetchall()
        skips = self.db.execute(
            "SELECT part_counts, program, reason FROM skipped ORDER BY id DESC LIMIT ?", (last,)
        ).fetchall()
        gaps = self.db.execute(
            "SELECT first_lost, last_lost, reason FROM gaps ORDER BY id DESC LIMIT ?", (last,)
        ).fetchall()
        skipped_parts = self.db.execute(
            "SELECT coalesce(sum(json_array_length(part_counts)), 0) FROM skipped"
        ).fetchone()[0]
        point = self.checkpoint()
        return {
            "pending": counts.get("pending", 0),
            "sent": counts.get("sent", 0),
            "rejected": counts.get("rejected", 0),
            "skipped_parts": skipped_parts,
            "gaps": self.db.execute("SELECT count(*) FROM gaps").fetchone()[0],
            "checkpoint": None
            if point is None
            else {"source": point.source, "instance": point.instance, "next": point.next_sequence},
            "recent": [
                {"part_count": r[0], "program": r[1], "state": r[2], "status": r[3], "tries": r[4]}
                for r in recent
            ],
            "recent_skipped": [
                {"part_counts": json.loads(r[0]), "program": r[1], "reason": r[2]} for r in skips
            ],
            "recent_gaps": [{"first": r[0], "last": r[1], "reason": r[2]} for r in gaps],
        }


def open_queue(path: Path) -> Queue:
    """Open (create) the queue file: WAL, ``synchronous=FULL``, autocommit off."""
    path.parent.mkdir(parents=True, exist_ok=True)
    db = sqlite3.connect(path, isolation_level=None, timeout=30.0)
    db.execute("PRAGMA journal_mode=WAL")
    db.execute("PRAGMA synchronous=FULL")
    db.executescript(_SCHEMA)
    return Queue(db)
