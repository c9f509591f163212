"""The plans and machines a fleet prior names: at most :data:`MAX_NAMED` of each, and the count.

A prior's provenance (``plans.prior``, ``plans.noise_prior``) is answered with every setpoint
an MES reads, once a part: listing every plan of a large fleet there (32 machines with ten
plans each: 320 names a quantity, 44 kB a ``GET /setpoints``) made each answer grow with the
fleet. It lists the first :data:`MAX_NAMED` names of each, sorted, with ``plans_total`` and
``machines_total``; ``rcb fleet show TOOL`` (``GET /tools/{name}/fleet``) lists every plan,
a page at a time. A prior stored before the counts were (every name listed) is answered the
same way: its counts are its lists' lengths, its lists cut to :data:`MAX_NAMED`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

#: The names a provenance lists of its plans, and of its machines.
MAX_NAMED = 10
#: The name lists a provenance may hold, each with its count ``<name>_total``.
NAMED = ("plans", "machines")


def listed(field: str, names: Sequence[str]) -> dict[str, Any]:
    """``{field: the first MAX_NAMED names, sorted; field_total: how many}``."""
    return {field: sorted(names)[:MAX_NAMED], f"{field}_total": len(names)}


def bounded(provenance: Mapping[str, Any], names: bool = True) -> dict[str, Any]:
    """A stored provenance as answered: each name list cut, its count given.

    ``names`` False (a key scoped to plans): the lists are null, the counts stay.
    """
    out = dict(provenance)
    for field in NAMED:
        if field not in out:
            continue
        stored = out[field] or []
        out[f"{field}_total"] = int(out.get(f"{field}_total", len(stored)))
        out[field] = list(stored[:MAX_NAMED]) if names else None
    return out
