"""``--since`` of the commands that read history (``rcb audit``, ``rcb parts``): from when on.

An age before now (``7d``, ``24h``, ``90m``, as :func:`api.services.retention.parse_duration`
reads it) or an ISO 8601 date or time; a time without an offset is UTC.
"""

from __future__ import annotations

import re
from datetime import datetime

from api.services.retention import parse_duration
from db.table_base import as_utc, utcnow
from models.errors import InputError


def since_of(text: str | None, now: datetime | None = None) -> datetime | None:
    """``--since`` as a UTC time, None without one; InputError naming ``--since`` otherwise."""
    if text is None:
        return None
    if re.fullmatch(r"\s*[0-9]+[dhm]\s*", text):
        return (now or utcnow()) - parse_duration("--since", text)
    try:
        moment = datetime.fromisoformat(text)
    except ValueError:
        raise InputError(
            "--since", text, "expected an age (7d, 24h, 90m) or an ISO 8601 date or time"
        ) from None
    return as_utc(moment)
