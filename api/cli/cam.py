"""``rcb cam depthmap``: roughing and finishing G-code from a greyscale depth map.

Borangiu et al. (IFAC 2007) §3: the chain is :func:`supervisor.cam.job.run_cam`; this module
reads the options, shows progress, prints the summary or the JSON, and writes the program
(atomically, only when everything succeeded) and the preview. scikit-image, shapely and
matplotlib are imported inside the command, so ``rcb`` starts without them.

Errors follow ``rcb`` (exit 2, one line naming the option and the value).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console

from api.cli.cam_options import (
    AllowanceOption,
    FinishDirectionOption,
    FinishOperationOption,
    FinishOption,
    FormToleranceOption,
    ImageArgument,
    MaxArcRadiusOption,
    NegativeOption,
    OperationOption,
    OutOption,
    PixelOption,
    PlanOption,
    PreviewOption,
    StepoverOption,
    StockTopOption,
    ToolOption,
    VerifyOption,
    ZRangeOption,
)
from api.cli.common import JsonOption, check_target, emit, errors, write_atomically
from api.cli.tables import new_table
from models.errors import InputError

if TYPE_CHECKING:
    from supervisor.cam.cutter import Cutter
    from supervisor.cam.depthmap import DepthMap
    from supervisor.cam.feeds import Feeds
    from supervisor.cam.job import CamResult

cam_app = typer.Typer(
    help="Machining programs from depth maps (Borangiu et al. §3).", no_args_is_help=True
)
_out = Console()

#: The option each field of :mod:`supervisor.cam` is given by.
OPTIONS = {
    "image": "IMAGE",
    "pixel_mm": "--pixel-mm",
    "z_range_mm": "--z-range-mm",
    "stock_top_mm": "--stock-top-mm",
    "tool": "--tool",
    "finish": "--finish",
    "stepover_mm": "--stepover-mm",
    "finish_direction": "--finish-direction",
    "form_tolerance_mm": "--form-tolerance-mm",
    "allowance_mm": "--allowance-mm",
    "operation": "--operation",
    "finish_operation": "--finish-operation",
}


@contextmanager
def _options() -> Iterator[None]:
    """Name the command-line option in an error from :mod:`supervisor.cam`."""
    try:
        yield
    except InputError as err:
        if err.field in OPTIONS:
            raise InputError(OPTIONS[err.field], err.value, err.reason) from None
        raise


def _bounded(value: float, option: str, low: float, high: float) -> float:
    if not (low <= value <= high):
        raise InputError(option, value, f"must be {low:g} to {high:g}")
    return value


@cam_app.command("depthmap")
def depthmap(
    image: ImageArgument,
    pixel_mm: PixelOption,
    z_range_mm: ZRangeOption,
    tool: ToolOption,
    plan: PlanOption,
    operation: OperationOption,
    out: OutOption,
    finish: FinishOption = None,
    finish_operation: FinishOperationOption = None,
    stepover_mm: StepoverOption = 0.5,
    finish_direction: FinishDirectionOption = "y",
    negative: NegativeOption = False,
    stock_top_mm: StockTopOption = None,
    allowance_mm: AllowanceOption = 0.5,
    form_tolerance_mm: FormToleranceOption = None,
    max_arc_radius_mm: MaxArcRadiusOption = 200.0,
    preview: PreviewOption = None,
    verify: VerifyOption = False,
    as_json: JsonOption = False,
) -> None:
    """Roughing (constant Z) and finishing (iso-parametric) G-code of a depth map."""
    with errors():
        from supervisor.cam.depthmap import parse_z_range, read_depthmap
        from supervisor.cam.job import CamSettings, run_cam

        _check_targets(out, preview)
        tolerance_mm = _check_numbers(
            allowance_mm, form_tolerance_mm, stepover_mm, max_arc_radius_mm, finish is not None
        )
        with _options():
            rough_cutter, finish_cutter, direction = _cutters(tool, finish, finish_direction)
            z_range = parse_z_range(z_range_mm)
            depth = read_depthmap(
                image, pixel_mm, z_range, negative=negative, stock_top_mm=stock_top_mm
            )
            _check_cutters(depth, tool, rough_cutter, finish_cutter)
            feeds, finishing = _feeds(
                plan, operation, rough_cutter, finish_cutter, finish_operation
            )
            settings = CamSettings(
                allowance_mm, tolerance_mm, stepover_mm, direction, max_arc_radius_mm
            )
            with _progress(not as_json) as tell:
                result = run_cam(
                    depth,
                    rough_cutter,
                    feeds,
                    finishing,
                    settings,
                    verify=verify,
                    title=f"rcb cam depthmap {image.name}",
                    progress=tell,
                )
        _write(out, preview, depth, result)
    if as_json:
        emit(result_json(result))
        return
    _print(result, out)


def _check_targets(out: Path, preview: Path | None) -> None:
    """The program and the preview can be written; a preview is a PNG or an SVG."""
    check_target(out)
    if preview is not None:
        check_target(preview, "--preview")
        if preview.suffix.lower() not in (".png", ".svg"):
            raise InputError("--preview", str(preview), "must end in .png or .svg")


def _check_numbers(
    allowance_mm: float,
    form_tolerance_mm: float | None,
    stepover_mm: float,
    max_arc_radius_mm: float,
    finishing: bool,
) -> float:
    """Check the numeric options; the form tolerance [mm], its default filled in."""
    from supervisor.cam.job import default_form_tolerance_mm

    _bounded(allowance_mm, "--allowance-mm", 0.0, 10.0)
    if form_tolerance_mm is None:
        form_tolerance_mm = default_form_tolerance_mm(allowance_mm, finishing)
    _bounded(form_tolerance_mm, "--form-tolerance-mm", 0.001, 10.0)
    _bounded(stepover_mm, "--stepover-mm", 0.001, 100.0)
    _bounded(max_arc_radius_mm, "--max-arc-radius-mm", 0.0, 1.0e5)
    return form_tolerance_mm


def _cutters(
    tool: str, finish: str | None, finish_direction: str
) -> tuple[Cutter, Cutter | None, str | float]:
    """The roughing cutter, the finishing cutter (if any) and the finishing direction."""
    from supervisor.cam.cutter import parse_cutter
    from supervisor.cam.finishing import parse_direction

    rough_cutter = parse_cutter(tool, "tool")
    finish_cutter = None if finish is None else parse_cutter(finish, "finish")
    return rough_cutter, finish_cutter, parse_direction(finish_direction)


def _check_cutters(
    depth: DepthMap, tool: str, rough_cutter: Cutter, finish_cutter: Cutter | None
) -> None:
    """Roughing takes a flat end mill; each cutter fits the depth map."""
    from supervisor.cam.job import check_cutter

    if rough_cutter.kind != "flat":
        raise InputError("tool", tool, "roughing needs a flat end mill (flat:D)")
    check_cutter(depth, rough_cutter, "tool")
    if finish_cutter is not None:
        check_cutter(depth, finish_cutter, "finish")


def _feeds(
    plan: Path,
    operation: str,
    rough_cutter: Cutter,
    finish_cutter: Cutter | None,
    finish_operation: str | None,
) -> tuple[Feeds, tuple[Cutter, Feeds] | None]:
    """The feeds of the plan's roughing operation, and of its finishing one with its cutter."""
    from supervisor.cam.feeds import Feeds, milling_operation
    from supervisor.inputs.plan import load_plan

    if not plan.is_file():
        raise InputError("--plan", str(plan), "no such file")
    loaded = load_plan(plan)
    feeds = Feeds(loaded, milling_operation(loaded, operation, rough_cutter, "operation"))
    if finish_cutter is None:
        return feeds, None
    name = finish_operation or "finish"
    op = milling_operation(loaded, name, finish_cutter, "finish_operation")
    return feeds, (finish_cutter, Feeds(loaded, op))


def _write(out: Path, preview: Path | None, depth: DepthMap, result: CamResult) -> None:
    """Write the program (atomically) and, with ``--preview``, draw its paths."""
    write_atomically(out, result.program.encode())
    if preview is not None:
        from api.cli.cam_preview import draw_preview

        draw_preview(depth, result, preview)


@contextmanager
def _progress(show: bool) -> Iterator[Any]:
    if not (show and sys.stderr.isatty()):
        yield None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    tasks: dict[str, Any] = {}
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as bar:

        def tell(stage: str, done: int, total: int) -> None:
            if stage not in tasks:
                tasks[stage] = bar.add_task(stage, total=total)
            bar.update(tasks[stage], completed=done)

        yield tell


def result_json(result: CamResult) -> dict[str, Any]:
    """``--json``: the levels, the pass count, the finishing and what the simulation found."""
    levels = [
        {
            "z_mm": r.paths.level.z_mm,
            "depth_mm": r.paths.level.depth_mm,
            "paths": len(r.paths.paths),
            "length_mm": r.paths.length_mm,
            "setpoint": r.setpoint.as_json(),
            "time_min": r.time_min,
        }
        for r in result.levels
    ]
    finishing = None
    finish_min = 0.0
    f = result.finishing
    if f is not None:
        finish_min = f.length_mm / f.setpoint.feed_rate_mm_min
        finishing = {
            "tool": f.cutter.describe(),
            "direction": f.direction,
            "stepover_mm": f.stepover_mm,
            "lines": len(f.lines),
            "length_mm": f.length_mm,
            "setpoint": f.setpoint.as_json(),
            "scallop_mm": f.scallop_mm,
            "time_min": finish_min,
        }
    v = result.verification
    cutting = sum(r.time_min for r in result.levels) + finish_min
    return {
        "levels": levels,
        "passes": len(levels),
        "finishing": finishing,
        "gouge_mm": None if v is None else v.gouge_mm,
        "max_remaining_stock_mm": None if v is None else v.max_remaining_stock_mm,
        "cycle_time_min": cutting if v is None else v.cycle_time_min,
    }


def _print(result: CamResult, out: Path) -> None:
    table = new_table(
        "from Z",
        "to Z",
        "passes",
        "Δ mm",
        "least slope",
        title=f"Roughing: {len(result.levels)} levels (Borangiu Δ_j, c_j)",
    )
    for b in result.bands:
        slope = "wall" if b.slope is None else f"{b.slope:.3f}"
        table.add_row(
            f"{b.top_mm:.3f}", f"{b.bottom_mm:.3f}", str(b.count), f"{b.step_mm:.4f}", slope
        )
    _out.print(table)
    lim = result.limits
    _out.print(
        f"optimiser limits: ap <= {lim.max_axial_depth_mm:.3f} mm, ae <= "
        f"{lim.max_radial_depth_mm:.3f} mm; stepover {lim.stepover_mm:.3f} mm",
        soft_wrap=False,
    )
    speeds = sorted({r.setpoint.spindle_rpm for r in result.levels})
    feeds = sorted({r.setpoint.feed_rate_mm_min for r in result.levels})
    if speeds:
        _out.print(
            f"roughing S {speeds[0]}-{speeds[-1]} rpm, F {feeds[0]:g}-{feeds[-1]:g} mm/min",
            soft_wrap=False,
        )
    f = result.finishing
    if f is not None:
        _out.print(
            f"finishing {f.cutter.describe()}: {len(f.lines)} lines, stepover "
            f"{f.stepover_mm:.3f} mm, scallop {f.scallop_mm:.4f} mm, "
            f"S {f.setpoint.spindle_rpm} F {f.setpoint.feed_rate_mm_min:g}",
            soft_wrap=False,
        )
    v = result.verification
    if v is not None:
        _out.print(
            f"verified: gouge {v.gouge_mm:.4f} mm, stock after roughing "
            f"{v.max_remaining_stock_mm:.4f} mm, cycle {v.cycle_time_min:.1f} min",
            soft_wrap=False,
        )
    _out.print(f"wrote {out}", soft_wrap=True)
