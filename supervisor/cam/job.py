"""The whole chain: depth map → levels → paths → setpoints → G-code → verification.

:func:`run_cam` is what ``rcb cam depthmap`` runs (:mod:`api.cli.cam`); each step is a module
of this package. ``progress(stage, done, total)`` is called as the long steps advance.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from models.errors import InputError
from supervisor.cam.compensation import offset_surface
from supervisor.cam.cutter import Cutter
from supervisor.cam.depthmap import DepthMap
from supervisor.cam.dropcutter import drop_map, drop_rows
from supervisor.cam.feeds import CuttingLimits, Feeds, PathSetpoint
from supervisor.cam.finishing import iso_lines, line_indices, scallop_height_mm
from supervisor.cam.levels import Band, Level, roughing_levels, slope_map
from supervisor.cam.motion import read_moves
from supervisor.cam.program import FINISH_TOOL, ROUGH_TOOL, Pass, write_program
from supervisor.cam.roughing import LevelPaths, rough
from supervisor.cam.verify import Verification, simulate

Progress = Callable[[str, int, int], None]


#: The stair a constant-Z level may leave when roughing is the last pass [mm].
FORM_TOLERANCE_MM = 0.04


def default_form_tolerance_mm(allowance_mm: float, finishing: bool) -> float:
    """The form tolerance when none is given [mm].

    Before a finishing pass the stair only has to be no thicker than the stock the finisher
    is planned for: it cuts at the allowance plus the form tolerance (:func:`run_cam` plans
    its setpoint at that depth), so a stair of the allowance doubles that depth at most and
    the finisher's setpoint is planned for it. ``moon.png`` (512 px at 0.25 mm, z 0-4 mm,
    Ø10 flat, Ø6 ball): 89 roughing levels and 267 min at 0.04 mm, 10 levels and 61 min
    at the allowance (0.5 mm). Without a finishing pass the levels are the final form:
    :data:`FORM_TOLERANCE_MM`.
    """
    return allowance_mm if finishing and allowance_mm > 0 else FORM_TOLERANCE_MM


@dataclass(frozen=True)
class CamSettings:
    """Choices of one run [mm]; the defaults are the command line's without ``--finish``."""

    allowance_mm: float = 0.5
    form_tolerance_mm: float = FORM_TOLERANCE_MM
    finish_stepover_mm: float = 0.5
    finish_direction: str | float = "y"
    max_arc_radius_mm: float = 200.0


@dataclass(frozen=True)
class LevelReport:
    """One roughing level: its paths, their length, setpoint and cutting time."""

    paths: LevelPaths
    setpoint: PathSetpoint

    @property
    def time_min(self) -> float:
        """Length over feed rate [min]."""
        return self.paths.length_mm / self.setpoint.feed_rate_mm_min


@dataclass(frozen=True)
class Finishing:
    """The finishing paths and what they leave."""

    cutter: Cutter
    lines: tuple[NDArray[np.float64], ...]
    stepover_mm: float
    direction: str | float
    setpoint: PathSetpoint
    scallop_mm: float

    @property
    def length_mm(self) -> float:
        """Length of the finishing lines [mm]."""
        return float(sum(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in self.lines))


@dataclass(frozen=True)
class CamResult:
    """Everything one run made."""

    program: str
    limits: CuttingLimits
    levels: tuple[LevelReport, ...]
    bands: tuple[Band, ...]
    finishing: Finishing | None
    verification: Verification | None


def check_cutter(depthmap: DepthMap, cutter: Cutter, field: str) -> None:
    """A cutter wider than the map cannot machine it."""
    side = min(depthmap.width_mm, depthmap.length_mm)
    if cutter.diameter_mm >= side:
        raise InputError(field, cutter.describe(), f"is as wide as the part or wider ({side:g} mm)")
    if cutter.radius_mm < depthmap.pixel_mm:
        raise InputError(
            field, cutter.describe(), f"is smaller than two pixels ({depthmap.pixel_mm:g} mm)"
        )


def run_cam(
    depthmap: DepthMap,
    cutter: Cutter,
    feeds: Feeds,
    finish: tuple[Cutter, Feeds] | None,
    settings: CamSettings,
    *,
    verify: bool = False,
    title: str = "rcb cam",
    progress: Progress | None = None,
) -> CamResult:
    """Roughing (and finishing) program of a depth map (package docstring)."""
    _check_cutters(depthmap, cutter, finish, settings)
    tell = progress or (lambda stage, done, total: None)
    limits = feeds.limits(cutter)
    reports, bands = _roughing(depthmap, cutter, feeds, limits, settings, tell)
    passes = [
        Pass(_title(i, len(reports), r.paths.level), r.setpoint, r.paths.paths, r.paths.level.z_mm)
        for i, r in enumerate(reports, start=1)
        if r.paths.paths
    ]
    finishing = None if finish is None else _finishing(depthmap, finish, settings, tell)
    program = write_program(
        title,
        depthmap.stock_top_mm,
        (cutter, passes),
        None
        if finishing is None
        else (
            finishing.cutter,
            Pass(f"finishing {finishing.cutter.describe()}", finishing.setpoint, finishing.lines),
        ),
        settings.max_arc_radius_mm,
    )
    verification = None
    if verify:
        verification = _verify(depthmap, program, cutter, finishing, settings, tell)
    return CamResult(program, limits, reports, tuple(bands), finishing, verification)


def _check_cutters(
    depthmap: DepthMap, cutter: Cutter, finish: tuple[Cutter, Feeds] | None, settings: CamSettings
) -> None:
    """Refuse cutters that cannot machine the map, before any work: roughing needs a flat one."""
    if cutter.kind != "flat":
        raise InputError("tool", cutter.describe(), "roughing needs a flat end mill (flat:D)")
    check_cutter(depthmap, cutter, "tool")
    if finish is not None:
        check_cutter(depthmap, finish[0], "finish")
        if settings.finish_stepover_mm > finish[0].diameter_mm / 2:
            raise InputError(
                "stepover_mm", settings.finish_stepover_mm, "must be at most the finishing radius"
            )


def _roughing(
    depthmap: DepthMap,
    cutter: Cutter,
    feeds: Feeds,
    limits: CuttingLimits,
    settings: CamSettings,
    tell: Progress,
) -> tuple[tuple[LevelReport, ...], list[Band]]:
    """The roughing levels over the offset surface, their paths and each one's setpoint."""
    p = depthmap.pixel_mm
    surface = offset_surface(depthmap.height_mm, settings.allowance_mm, p)
    slope = slope_map(depthmap.height_mm, p, depthmap.grey_level_mm, settings.form_tolerance_mm)
    plateau = max(1, math.ceil(math.pi * cutter.radius_mm**2 / p**2))
    levels, bands = roughing_levels(
        surface,
        depthmap.height_mm,
        slope,
        settings.allowance_mm,
        depthmap.stock_top_mm,
        limits.max_axial_depth_mm,
        settings.form_tolerance_mm,
        plateau,
    )
    total = len(levels)
    paths = rough(
        surface,
        p,
        levels,
        cutter.radius_mm,
        limits.stepover_mm,
        lambda done: tell("roughing", done, total),
    )
    reports = tuple(
        LevelReport(lp, feeds.at(lp.level.depth_mm, limits.stepover_mm)) for lp in paths
    )
    return reports, bands


def _finishing(
    depthmap: DepthMap, finish: tuple[Cutter, Feeds], settings: CamSettings, tell: Progress
) -> Finishing:
    """Iso-lines over the finishing cutter's tip surface, at the allowance plus the tolerance.

    The setpoint is planned for that depth: the stock the roughing stair leaves at most.
    """
    tell("finishing", 0, 1)
    fcutter, ffeeds = finish
    tip = _tip_surface(depthmap.height_mm, fcutter, depthmap.pixel_mm, settings)
    lines, step = iso_lines(
        tip, depthmap.pixel_mm, settings.finish_stepover_mm, settings.finish_direction
    )
    depth = settings.allowance_mm + settings.form_tolerance_mm
    finishing = Finishing(
        fcutter,
        tuple(lines),
        step,
        settings.finish_direction,
        ffeeds.at(depth, step),
        scallop_height_mm(fcutter, step),
    )
    tell("finishing", 1, 1)
    return finishing


def _verify(
    depthmap: DepthMap,
    program: str,
    cutter: Cutter,
    finishing: Finishing | None,
    settings: CamSettings,
    tell: Progress,
) -> Verification:
    """The program's moves cut from the stock and compared with the map, near the surface."""
    tell("verifying", 0, 1)
    p = depthmap.pixel_mm
    cutters = {ROUGH_TOOL: cutter}
    if finishing is not None:
        cutters[FINISH_TOOL] = finishing.cutter
    window = settings.allowance_mm + settings.form_tolerance_mm + 2 * p
    verification = simulate(
        depthmap.height_mm, p, depthmap.stock_top_mm, read_moves(program), cutters, window
    )
    tell("verifying", 1, 1)
    return verification


def _tip_surface(
    height_mm: NDArray[np.float64], cutter: Cutter, pixel_mm: float, settings: CamSettings
) -> NDArray[np.float64]:
    """The cutter dropped on the triangulated surface where the finishing lines need it.

    NaN elsewhere (:mod:`supervisor.cam.dropcutter`).
    """
    direction = settings.finish_direction
    if direction not in ("x", "y"):
        return drop_map(height_mm, cutter, pixel_mm)
    step = max(1, round(settings.finish_stepover_mm / pixel_mm))
    grid = height_mm if direction == "y" else height_mm.T
    index = np.asarray(line_indices(grid.shape[0], step))
    tip = np.full(grid.shape, np.nan)
    tip[index] = drop_rows(grid, cutter, pixel_mm, index)
    return tip if direction == "y" else np.ascontiguousarray(tip.T)


def _title(index: int, total: int, level: Level) -> str:
    return (
        f"level {index} of {total}, {level.kind}, Z{level.z_mm:.4f}, depth {level.depth_mm:.4f} mm"
    )
