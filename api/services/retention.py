"""How long audit entries, idempotency records and replaced band states are kept: rcb db prune.

Band states are deleted a batch at a time (:data:`STATES_BATCH`), each batch its own short
transaction, so that a first prune of a year's states does not hold a SQLite database's write
lock while the MES reports parts; each band's newest state is never deleted
(:mod:`db.state_retention`). Durations are written as a number and a unit, ``365d``, ``24h``,
``90m``. Idempotency records are kept at least 24 hours, as
draft-ietf-httpapi-idempotency-key-header asks of a server that honours a key (a retry within a
day must find its first answer).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import request_limits
from db import api_keys, audit, state_retention
from db import tables as t
from models.errors import InputError

#: The default retention of the audit log.
AUDIT_DEFAULT = request_limits.AUDIT_DEFAULT
#: The default retention of idempotency records.
IDEMPOTENCY_DEFAULT = request_limits.IDEMPOTENCY_DEFAULT
#: The default retention of band states a newer one replaced.
STATES_DEFAULT = request_limits.STATES_DEFAULT
#: Band states deleted per transaction.
STATES_BATCH = 2000
#: The shortest retention of idempotency records.
IDEMPOTENCY_MIN = timedelta(hours=24)
#: The longest duration accepted (100 years).
LONGEST = timedelta(days=36_500)
_UNITS = {"d": "days", "h": "hours", "m": "minutes"}


def parse_duration(option: str, text: str) -> timedelta:
    """``365d``, ``24h`` or ``90m`` as a timedelta; InputError naming ``option`` otherwise."""
    match = re.fullmatch(r"([0-9]+)([dhm])", text.strip())
    if match is None:
        raise InputError(option, text, "expected a whole number and d, h or m, e.g. 365d")
    digits = match[1].lstrip("0")
    if len(digits) > 9:  # more than LONGEST in any unit, and beyond what timedelta holds
        raise InputError(option, text, "more than 0 and at most 36500d")
    duration = timedelta(**{_UNITS[match[2]]: int(digits or "0")})
    if not timedelta(0) < duration <= LONGEST:
        raise InputError(option, text, "more than 0 and at most 36500d")
    return duration


def prune(
    *,
    engine: Engine,
    audit_older_than: str = AUDIT_DEFAULT,
    idempotency_older_than: str = IDEMPOTENCY_DEFAULT,
    states_older_than: str = STATES_DEFAULT,
    actor: api_keys.Actor = api_keys.CLI_ACTOR,
) -> dict[str, Any]:
    """Delete audit entries, idempotency records and replaced band states older than the ages.

    The band states first, a batch per transaction (module docstring); then the audit entries
    and idempotency records in one transaction with the audit entry that says what was deleted.
    Returns ``{"audit_log": n, "idempotency_records": m, "band_states": s, "audit_before",
    "idempotency_before", "states_before"}``. Raises InputError (naming the option) for a
    malformed age, or an idempotency age under 24 h, before anything is deleted. ``actor``: who
    prunes, for the audit entry the pruning leaves (``rcb db prune --by``).
    """
    audit_age = parse_duration("--audit-older-than", audit_older_than)
    idem_age = parse_duration("--idempotency-older-than", idempotency_older_than)
    states_age = parse_duration("--states-older-than", states_older_than)
    if idem_age < IDEMPOTENCY_MIN:
        raise InputError(
            "--idempotency-older-than",
            idempotency_older_than,
            "idempotency records are kept at least 24h (a retry within a day finds its answer)",
        )
    now = t.utcnow()
    before = {
        "audit_before": now - audit_age,
        "idempotency_before": now - idem_age,
        "states_before": now - states_age,
    }
    states = _prune_states(engine, before["states_before"])
    with Session(engine) as session, session.begin():
        deleted = audit.prune(
            session=session,
            audit_before=before["audit_before"],
            idempotency_before=before["idempotency_before"],
        )
        deleted["band_states"] = states
        audit.audit(
            session=session,
            actor=actor.name,
            action="prune",
            target=(
                f"older than {audit_older_than} / {idempotency_older_than} / {states_older_than}"
            ),
            result="ok",
            detail=dict(deleted),
        )
    return {**deleted, **before}


def _prune_states(engine: Engine, before: datetime) -> int:
    """Delete the band states no reader needs of parts received before ``before``; how many."""
    return sum(state_batches(engine, before))


def state_batches(engine: Engine, before: datetime) -> Iterator[int]:
    """Delete the band states no reader needs of parts received before ``before``, by batches.

    A batch per transaction, its count yielded once it is committed. It ends: each batch
    deletes what it found, and finds none twice.
    """
    while True:
        with Session(engine) as session, session.begin():
            ids = state_retention.prunable_states(
                session=session, before=before, limit=STATES_BATCH
            )
            done = state_retention.delete_states(session=session, ids=ids)
        yield done
        if len(ids) < STATES_BATCH:
            return
