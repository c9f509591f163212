"""``since`` of the reads of history (``rcb audit``, ``rcb parts``, ``GET .../parts``).

At the CLI (``--since``) an age before now (``7d``, ``24h``, ``90m``, as
:func:`api.services.retention.parse_duration` reads it) or an ISO 8601 date or time; over REST
(``since``) a date or time only, so that a walk of pages with one ``since`` lists one set of
parts. A time without an offset is UTC.
"""

from __future__ import annotations

import re
from datetime import datetime

from api.services.retention import parse_duration
from db.table_base import as_utc, utcnow
from models.errors import InputError

#: The longest text taken: an ISO 8601 time with microseconds and an offset is 32 characters.
LONGEST_TEXT = 40


def since_of(
    text: str | None, now: datetime | None = None, *, field: str = "--since", ages: bool = True
) -> datetime | None:
    """``text`` as a UTC time, None without one; InputError naming ``field`` otherwise.

    ``ages``: an age before ``now`` is taken too (the CLI's).
    """
    if text is None:
        return None
    if ages and re.fullmatch(r"\s*[0-9]+[dhm]\s*", text):
        return (now or utcnow()) - parse_duration(field, text)
    shown = text if len(text) <= LONGEST_TEXT else text[:LONGEST_TEXT] + "..."
    dates = "an ISO 8601 date or time"
    example = f"{dates}, e.g. 2026-12-01 or 2026-12-01T06:00:00Z"
    expected = f"an age (7d, 24h, 90m) or {dates}" if ages else example
    try:
        moment = datetime.fromisoformat(text) if len(text) <= LONGEST_TEXT else None
    except ValueError:
        moment = None
    if moment is None:
        raise InputError(field, shown, f"expected {expected}")
    try:
        return as_utc(moment)
    except OverflowError:  # 9999-12-31T23:59-05:00 is in the year 10000 in UTC
        raise InputError(field, shown, "outside the years 1 to 9999 in UTC") from None
