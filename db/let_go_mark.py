"""A stored prior's entry marked as let go by a part: its provenance says so on every surface.

Shared by the fleet priors of the models (``plans.prior``, :mod:`db.fleet`) and of the
measuring chains' noise (``plans.noise_prior``, :mod:`db.fleet_noise`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def marked(entry: Mapping[str, Any], field: str, serial: str, why: str) -> dict[str, Any]:
    """``entry`` with its provenance's ``field`` set to ``serial`` and its text saying ``why``."""
    provenance = dict(entry["provenance"])
    provenance[field] = serial
    provenance["text"] = f"{provenance['text']}; let go by part {serial}: {why}"
    return {**entry, "provenance": provenance}
