"""A matplotlib figure as SVG text for an HTML page: deterministic, small, ids unique.

:func:`render` draws a figure under :data:`STYLE` and :func:`to_svg` writes it: deterministic
(fixed ``svg.hashsalt``, no date), small (text kept as text, ``svg.fonttype = "none"``, unused
ids and the indentation dropped), and with ``id_prefix`` before every id so that several SVGs
in one HTML page have unique ids.
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import matplotlib
from matplotlib.figure import Figure

from api.report.svg_compact import compact

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType  # matplotlib >= 3.10; only for the checker

S = TypeVar("S")

#: Style of every figure: text stays text in the SVG, ids do not change from run to run.
STYLE: dict[RcKeyType, Any] = {
    "svg.fonttype": "none",
    "svg.hashsalt": "rcb-report",
    "font.size": 8.0,
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans", "Arial", "Helvetica"],  # named in every SVG text
    "axes.grid": True,
    "grid.alpha": 0.3,
    "lines.markersize": 4.0,
}
#: What matplotlib would write about itself and the date: nothing (the SVG stays the same).
_SVG_METADATA: dict[str, Any] = {"Creator": None, "Date": None, "Format": None, "Type": None}

_ID = re.compile(r'(\bid="|href="#|url\(#)')
_ID_ATTRIBUTE = re.compile(r' id="([^"]*)"')
_REFERENCE = re.compile(r'(?:href="#|url\(#)([^")]*)')


def to_svg(figure: Figure, id_prefix: str = "") -> str:
    """The figure as an SVG element (no XML declaration or DOCTYPE), compact, ids prefixed.

    Matplotlib's own group ids (``line2d_7`` ...) that nothing refers to are dropped, and so
    is the indentation; ids set on artists (``set_gid``) and referenced ids (markers, clip
    paths) stay, with ``id_prefix`` before them.

    Parameters
    ----------
    figure : Figure
        Drawn under :data:`STYLE` (see :func:`render`).
    id_prefix : str
        Put before every id and reference to one, so that several SVGs in one HTML page
        have unique ids; letters, digits, ``-`` and ``_`` only.
    """
    if not re.fullmatch(r"[A-Za-z0-9_-]*", id_prefix):
        raise ValueError(f"id_prefix = {id_prefix!r}: letters, digits, - and _ only")
    buffer = io.StringIO()
    with matplotlib.rc_context(STYLE):
        figure.savefig(buffer, format="svg", metadata=_SVG_METADATA)
    text = buffer.getvalue()
    text = re.sub(r"\n +", "\n", text[text.index("<svg") :].strip())
    kept = set(_REFERENCE.findall(text)) | {a.get_gid() for a in figure.findobj() if a.get_gid()}
    text = _ID_ATTRIBUTE.sub(lambda m: m.group(0) if m.group(1) in kept else "", text)
    text = compact(text)
    return _ID.sub(lambda m: f"{m.group(1)}{id_prefix}-", text) if id_prefix else text


def render(draw: Callable[[S], Figure], series: S, id_prefix: str = "") -> str:
    """Draw ``series`` with ``draw`` (a ``*_figure`` function) under :data:`STYLE`, as SVG."""
    with matplotlib.rc_context(STYLE):
        return to_svg(draw(series), id_prefix)
