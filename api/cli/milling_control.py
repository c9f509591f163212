"""``rcb milling control``: an inner feed-control loop on the virtual mill, against its paper.

``rcb milling control --controller pi|fuzzy|corrective --case kim-jeon-1 [--plot FILE]`` runs
:func:`supervisor.virtual.mill.run_case1` and prints, per depth segment, the steady feed and
the force deviation from the reference (mean and largest ``|F − F_ref|/F_ref`` over the last
third of the segment), the peak force, and what the paper reports for the case. ``--plot``
draws force and feed against time (SVG or PNG by the file's suffix), written atomically.

Errors follow ``rcb`` (exit 2, one line ``rcb: error: FIELD = VALUE: reason``).
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.common import check_target, emit, errors, write_atomically
from models.errors import InputError
from supervisor.virtual.mill import CONTROLLERS, MillRun, run_case1

_out = Console()
#: Plot formats by suffix.
FORMATS = {".svg": "svg", ".png": "png"}


@dataclass(frozen=True)
class PaperCase:
    """What a paper reports for a case: the feeds that held the force, the overshoot."""

    title: str
    source: str
    holding_feed_mm_min: dict[float, float]
    overshoot_force_N: float


#: The cases, by name (one line per case: its runner and what its paper reports).
CASES: dict[str, PaperCase] = {
    "kim-jeon-1": PaperCase(
        title="Kim & Jeon Case 1: Al6061-T6, depth 1.5 → 3.0 → 1.5 mm, 160 N",
        # §5.1: the FLC "increased the feed rate to 190 mpm" at 1.5 mm and lowered it "to 70
        # mpm" at 3.0 mm (Fig. 5c); §5.2: "the cutting force overshoot to 300 N"
        source="Kim & Jeon, Precision Engineering 2011, §5.1-5.2, Fig. 5c",
        holding_feed_mm_min={1.5: 190.0, 3.0: 70.0},
        overshoot_force_N=300.0,
    ),
}


def control(
    controller: Annotated[
        str, typer.Option("--controller", help=f"One of: {', '.join(CONTROLLERS)}.")
    ],
    case: Annotated[str, typer.Option("--case", help=f"One of: {', '.join(CASES)}.")] = (
        "kim-jeon-1"
    ),
    seed: Annotated[int, typer.Option("--seed", help="Seed of the sensor noise.")] = 0,
    plot: Annotated[
        Path | None,
        typer.Option("--plot", help="Draw force and feed against time here (.svg or .png)."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """Run a feed controller on a paper's milling case; print the force deviation per segment."""
    with errors():
        if controller not in CONTROLLERS:
            raise InputError("--controller", controller, f"one of: {', '.join(CONTROLLERS)}")
        if case not in CASES:
            raise InputError("--case", case, f"one of: {', '.join(CASES)}")
        if plot is not None:
            if plot.suffix.lower() not in FORMATS:
                raise InputError("--plot", str(plot), "the suffix names the format: .svg or .png")
            check_target(plot, "--plot")
        if not 0 <= seed < 2**63:
            raise InputError("--seed", seed, "a seed is 0 to 2**63 - 1")
        run = run_case1(controller, seed=seed)
        paper = CASES[case]
        if plot is not None:
            write_atomically(plot, figure_bytes(run, controller, paper, plot), "--plot")
    document = control_json(run, controller, case, paper)
    if as_json:
        emit(document)
        return
    _out.print(_table(document, paper))
    if plot is not None:
        _out.print(f"rcb: plot written to {plot}", markup=False, highlight=False)


def control_json(run: MillRun, controller: str, case: str, paper: PaperCase) -> dict[str, Any]:
    """The run's segments with their deviation, peak force and the paper's numbers."""
    segments = []
    for s in run.segments:
        inside = (run.time_s >= s.start_s) & (run.time_s <= s.end_s)
        segments.append(
            {
                "depth_mm": s.depth_mm,
                "start_s": s.start_s,
                "end_s": s.end_s,
                "deviation_mean_rel": s.deviation_mean_rel,
                "deviation_max_rel": s.deviation_max_rel,
                "feed_mean_steady_mm_min": s.feed_mean_steady_mm_min,
                "peak_force_N": float(run.force_N[inside].max()),
                "paper_feed_mm_min": paper.holding_feed_mm_min.get(s.depth_mm),
            }
        )
    return {
        "case": case,
        "controller": controller,
        "reference_force_N": run.reference_force_N,
        "segments": segments,
        "paper": {
            "source": paper.source,
            "holding_feed_mm_min": {f"{d:g}": f for d, f in paper.holding_feed_mm_min.items()},
            "overshoot_force_N": paper.overshoot_force_N,
        },
    }


def _table(document: dict[str, Any], paper: PaperCase) -> Table:
    title = f"{paper.title}; controller {document['controller']}"
    table = Table(
        title=title,
        caption=f"paper: {paper.source}; overshoot {paper.overshoot_force_N:g} N at the step up",
        caption_justify="left",
    )
    for column in ("depth mm", "feed mm/min", "paper", "dev. mean %", "dev. max %", "peak N"):
        table.add_column(column, justify="right")
    for s in document["segments"]:
        table.add_row(
            f"{s['depth_mm']:g}",
            f"{s['feed_mean_steady_mm_min']:.1f}",
            "-" if s["paper_feed_mm_min"] is None else f"{s['paper_feed_mm_min']:g}",
            f"{100 * s['deviation_mean_rel']:.2f}",
            f"{100 * s['deviation_max_rel']:.2f}",
            f"{s['peak_force_N']:.0f}",
        )
    return table


def figure_bytes(run: MillRun, controller: str, paper: PaperCase, path: Path) -> bytes:
    """Force (with the reference) and feed (with the depth) against time, as SVG or PNG."""
    # imported here: matplotlib takes about 0.3 s to import, and only --plot needs it
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    figure = Figure(figsize=(8.0, 5.0), layout="constrained")
    force, feed = figure.subplots(2, 1, sharex=True)
    force.plot(run.time_s, run.force_N, linewidth=0.8, label="force")
    force.axhline(run.reference_force_N, color="black", linestyle="--", label="reference")
    force.set_ylabel("force [N]")
    force.set_title(f"{paper.title}; {controller}", fontsize=9)
    force.legend(loc="upper right", fontsize=8)
    feed.plot(run.time_s, run.feed_rate_mm_min, linewidth=0.8, label="feed rate")
    feed.set_ylabel("feed [mm/min]")
    feed.set_xlabel("time [s]")
    depth = feed.twinx()
    depth.step(run.time_s, run.depth_mm, where="post", color="grey", linewidth=0.8)
    depth.set_ylabel("depth of cut [mm]")
    kind = FORMATS[path.suffix.lower()]
    metadata: dict[str, Any] = {"Date": None} if kind == "svg" else {"Software": None}
    buffer = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "rcb"}):  # stable ids: the same run, same file
        figure.savefig(buffer, format=kind, metadata=metadata)
    return buffer.getvalue()
