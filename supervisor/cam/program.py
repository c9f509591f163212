"""The G-code program: ISO 6983 words, metric, absolute, XY plane, feed per minute.

``G21 G90 G17 G94``; a tool change (``T.. M6``) per cutter, ``S`` in rpm with ``M3`` per
setpoint, ``G0`` rapids at the clearance height between paths, a plunge at half the path's
feed rate, ``G1`` lines and ``G2``/``G3`` arcs (``I J`` incremental centre), each arc in one
quadrant and under the machine's largest radius (:mod:`supervisor.cam.arcs`); a comment per
level and per path. The project's own reader (:func:`supervisor.gcode.parse_program`) reads
every line of it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from supervisor.cam.arcs import fit_tables, to_moves
from supervisor.cam.cutter import Cutter
from supervisor.cam.feeds import PathSetpoint

#: Height of the rapid moves above the stock top [mm].
CLEARANCE_MM = 2.0
#: Tool numbers of the roughing and finishing cutters.
ROUGH_TOOL, FINISH_TOOL = 1, 2


@dataclass(frozen=True)
class Pass:
    """Paths cut with one setpoint: a roughing level (constant ``z``) or the finishing."""

    title: str
    setpoint: PathSetpoint
    paths: tuple[NDArray[np.float64], ...]  # (n, 2) at z_mm, or (n, 3)
    z_mm: float | None = None


def _n(value: float) -> str:
    text = f"{value:.4f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def write_program(
    title: str,
    stock_top_mm: float,
    roughing: tuple[Cutter, Sequence[Pass]],
    finishing: tuple[Cutter, Pass] | None,
    max_arc_radius_mm: float,
) -> str:
    """The program text (module docstring)."""
    safe = stock_top_mm + CLEARANCE_MM
    out = [
        "%",
        f"({_clean(title)})",
        "G21 G90 G17 G94",
    ]
    cutter, passes = roughing
    out += [f"T{ROUGH_TOOL} M6 (roughing {cutter.describe()})", f"G0 Z{_n(safe)}"]
    for p in passes:
        _emit_pass(out, p, safe, max_arc_radius_mm)
    if finishing is not None:
        fcutter, fpass = finishing
        out += ["M5", f"T{FINISH_TOOL} M6 (finishing {fcutter.describe()})", f"G0 Z{_n(safe)}"]
        _emit_pass(out, fpass, safe, max_arc_radius_mm)
    out += [f"G0 Z{_n(safe)}", "M5", "M30", "%"]
    return "\n".join(out) + "\n"


def _clean(text: str) -> str:
    return "".join(c for c in text if c.isprintable() and c not in "()")[:120]


def _emit_pass(out: list[str], p: Pass, safe: float, max_radius: float) -> None:
    sp = p.setpoint
    feed = sp.feed_rate_mm_min
    plunge = max(0.1, int(feed * 5) / 10)
    out.append(
        f"({_clean(p.title)}: ap {sp.axial_depth_mm:.3f} ae {sp.radial_depth_mm:.3f}"
        f" fz {sp.feed_per_tooth_mm:.4f} vc {sp.speed_m_min:.1f})"
    )
    out.append(f"S{sp.spindle_rpm} M3")
    flat = [path for path in p.paths if path.shape[1] == 2]
    tables = iter(fit_tables(flat, max_radius))
    for k, path in enumerate(p.paths, start=1):
        out.append(f"(path {k} of {len(p.paths)})")
        if path.shape[1] == 2:
            assert p.z_mm is not None
            out.append(f"G0 X{_n(path[0, 0])} Y{_n(path[0, 1])}")
            out.append(f"G1 Z{_n(p.z_mm)} F{plunge:g}")
            first = True
            for m in to_moves(path, max_radius, next(tables)):
                f = f" F{feed:g}" if first else ""
                first = False
                if m.centre is None:
                    out.append(f"G1 X{_n(m.x)} Y{_n(m.y)}{f}")
                else:
                    start = _last_xy(out)
                    i, j = m.centre[0] - start[0], m.centre[1] - start[1]
                    code = "G3" if m.ccw else "G2"
                    out.append(f"{code} X{_n(m.x)} Y{_n(m.y)} I{_n(i)} J{_n(j)}{f}")
        else:
            pts = _drop_collinear(path)
            out.append(f"G0 X{_n(pts[0, 0])} Y{_n(pts[0, 1])}")
            out.append(f"G1 Z{_n(pts[0, 2])} F{plunge:g}")
            for i, q in enumerate(pts[1:]):
                f = f" F{feed:g}" if i == 0 else ""
                out.append(f"G1 X{_n(q[0])} Y{_n(q[1])} Z{_n(q[2])}{f}")
        out.append(f"G0 Z{_n(safe)}")


def _last_xy(out: list[str]) -> tuple[float, float]:
    """The X and Y the previous motion lines end at (as written, so I and J match)."""
    x = y = None
    for line in reversed(out):
        if not line.startswith(("G0 ", "G1 ", "G2 ", "G3 ")):
            continue
        for word in line.split():
            if x is None and word.startswith("X"):
                x = float(word[1:])
            elif y is None and word.startswith("Y"):
                y = float(word[1:])
        if x is not None and y is not None:
            return x, y
    raise ValueError("no start point before an arc")


def _drop_collinear(points: NDArray[np.float64], tol_mm: float = 1e-7) -> NDArray[np.float64]:
    """Points without those whose neighbours are equally spaced on a line through them (3D).

    The points of an iso-parametric line are equally spaced in XY, so a point is dropped when
    its second difference vanishes; the simulation (:mod:`supervisor.cam.verify`) sweeps the
    program as written, so what is dropped is checked there.
    """
    if len(points) <= 2:
        return points
    second = np.abs(points[:-2] - 2 * points[1:-1] + points[2:]).max(axis=1)
    keep = np.concatenate(([True], second > tol_mm, [True]))
    return points[keep]
