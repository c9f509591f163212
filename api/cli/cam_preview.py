"""``rcb cam depthmap --preview``: the paths drawn over the depth map (matplotlib).

Roughing paths are coloured by their level (dark low, light high), finishing lines are thin
red; the depth map is the grey background, in mm. PNG or SVG by the file's suffix.
"""

from __future__ import annotations

from pathlib import Path

from supervisor.cam.depthmap import DepthMap
from supervisor.cam.job import CamResult

#: Largest number of finishing lines drawn (every k-th beyond that).
MAX_FINISH_LINES = 120


def draw_preview(depthmap: DepthMap, result: CamResult, path: Path) -> None:
    """Write the preview image to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    fig, ax = plt.subplots(
        figsize=(5.2, 5.2 * depthmap.length_mm / max(depthmap.width_mm, 1e-9) + 0.6)
    )
    ax.imshow(
        depthmap.height_mm,
        cmap="gray",
        extent=(0, depthmap.width_mm, 0, depthmap.length_mm),
        origin="upper",
        interpolation="nearest",
    )
    segments, heights = [], []
    for report in result.levels:
        for p in report.paths.paths:
            segments.append(p)
            heights.append(report.paths.level.z_mm)
    if segments:
        lines = LineCollection(segments, cmap="viridis", linewidths=0.6)
        lines.set_array(heights)
        ax.add_collection(lines)
        fig.colorbar(lines, ax=ax, label="roughing level Z [mm]", shrink=0.8)
    if result.finishing is not None:
        finish = result.finishing.lines
        step = max(1, len(finish) // MAX_FINISH_LINES)
        ax.add_collection(
            LineCollection([f[:, :2] for f in finish[::step]], colors="red", linewidths=0.3)
        )
    ax.set_xlim(-1, depthmap.width_mm + 1)
    ax.set_ylim(-1, depthmap.length_mm + 1)
    ax.set_xlabel("X [mm]")
    ax.set_ylabel("Y [mm]")
    count = len(result.levels)
    ax.set_title(f"{count} roughing levels" + ("; finishing in red" if result.finishing else ""))
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
