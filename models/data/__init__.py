"""Packaged data files, paper tables kept as data, and :func:`read_toml` that reads them.

- ``ivester_aisi1045.toml``: the built-in tool catalogue (Ivester & Heigel Tables 2-3, Eq. 8),
  read by :mod:`models.catalogue`.
- ``tai_end_milling.toml``: Tai, Tsai & Li's constant-load end milling (§II-§III), read by
  :mod:`supervisor.virtual.mill.tai_end_milling`.
- ``kim_jeon_case1.toml``: Kim & Jeon's Case 1 simulation (§5.1), read by
  :mod:`supervisor.virtual.mill.case1`.
- ``kim_jeon_current_force.toml``: Kim & Jeon's current → force relations at 4500 rpm
  (§6.2.3), read by :mod:`models.sensors.kim_jeon_feed`.

Each number carries its source (paper, section, table or figure) in a comment of its file.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from typing import Any


def read_toml(filename: str) -> dict[str, Any]:
    """The parsed content of the packaged data file ``filename``."""
    text = resources.files("models.data").joinpath(filename).read_text(encoding="utf-8")
    return tomllib.loads(text)
