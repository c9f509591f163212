"""Write the figures of docs/milling_control.md into docs/img/ (matplotlib, Agg backend).

Run from the repository root: ``.venv/bin/python docs/make_milling_plots.py``. Every run is
seeded, so the figures are the same each time.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from supervisor.virtual.mill import (  # noqa: E402
    EdgeLifeConfig,
    MillRun,
    run_case1,
    simulate_edge_life,
)

IMG = Path(__file__).resolve().parent / "img"
TITLES = {
    "pi": "Tai et al. PI (Eq. 16) on the spindle current, 50 Hz",
    "fuzzy": "Kim & Jeon fuzzy controller (Table 2), once per revolution",
    "corrective": "Borangiu et al. WINC/WDEC corrective actions (Table 1), once per revolution",
}
SEED = 0


def _case1_figure(name: str, run: MillRun) -> Figure:
    fig, (ax_d, ax_f, ax_v) = plt.subplots(
        3, 1, figsize=(7.5, 6.2), sharex=True, height_ratios=(1, 2, 2)
    )
    t = run.time_s
    ax_d.plot(t, run.depth_mm, color="0.3")
    ax_d.set_ylabel("depth [mm]")
    ax_d.set_ylim(0, 3.5)
    ref = run.reference_force_N
    ax_f.axhspan(0.95 * ref, 1.05 * ref, color="tab:green", alpha=0.15, label="±5 % of 160 N")
    ax_f.plot(t, run.force_N, color="tab:blue", lw=1.0, label="true F_max")
    if run.signal == "force_N":
        ax_f.plot(t, run.measured, color="tab:orange", lw=0.5, alpha=0.6, label="from current")
    ax_f.axhline(ref, color="k", lw=0.6, ls="--")
    ax_f.set_ylabel("force [N]")
    ax_f.set_ylim(0, 340)
    ax_f.legend(loc="upper right", fontsize=7, ncol=3)
    for segment in run.segments:
        ax_f.axvspan(segment.steady_from_s, segment.end_s, color="0.5", alpha=0.1, lw=0)
    lim = run.limits
    ax_v.plot(t, run.feed_command_mm_min, color="tab:red", lw=1.0, label="command")
    ax_v.plot(t, run.feed_rate_mm_min, color="tab:purple", lw=0.6, ls=":", label="actual")
    for value in (lim.lower_feed_rate_mm_min, lim.upper_feed_rate_mm_min):
        ax_v.axhline(value, color="k", lw=0.6, ls="--")
    ax_v.set_ylabel("feed [mm/min]")
    ax_v.set_xlabel("time [s]")
    ax_v.set_ylim(0, 260)
    ax_v.legend(loc="upper right", fontsize=7, ncol=2)
    fig.suptitle(f"Kim & Jeon Case 1 — {TITLES[name]}", fontsize=9)
    fig.tight_layout()
    return fig


def _edge_life_figure() -> Figure:
    config = EdgeLifeConfig()
    fig, (ax_w, ax_v, ax_i) = plt.subplots(3, 1, figsize=(7.5, 6.2), sharex=True)
    low, high = config.tool_change_interval_mm
    ax_w.axhspan(
        low * 1e3, high * 1e3, color="tab:green", alpha=0.15, label="tool change 180-220 µm"
    )
    for seed in range(5):
        edge = simulate_edge_life(config, np.random.default_rng(seed))
        run = edge.run
        length = run.position_mm
        step = max(1, len(length) // 400)
        ax_w.plot(length[::step], run.flank_wear_mm[::step] * 1e3, lw=1.0, label=f"seed {seed}")
        ax_w.plot(length[-1], edge.flank_wear_at_change_mm * 1e3, "ko", ms=3)
        ax_v.plot(length[::step], run.feed_command_mm_min[::step], lw=0.8)
        ends = [min(p.index * config.pass_length_mm, length[-1]) for p in edge.passes]
        ax_i.plot(ends, [p.current_mean_A for p in edge.passes], "o-", lw=0.8, ms=2.5)
    ax_w.set_ylabel("flank wear [µm]")
    ax_w.legend(loc="upper left", fontsize=7, ncol=3)
    for value in (config.limits.lower_feed_rate_mm_min, config.limits.upper_feed_rate_mm_min):
        ax_v.axhline(value, color="k", lw=0.6, ls="--")
    ax_v.set_ylabel("feed command [mm/min]")
    ref = config.reference_current_A
    ax_i.axhspan(0.99 * ref, 1.01 * ref, color="tab:green", alpha=0.15, label="±1 % of 0.24 A")
    ax_i.axhline(ref, color="k", lw=0.6, ls="--")
    ax_i.legend(loc="lower right", fontsize=7)
    ax_i.set_ylabel("true current,\npass mean [A]")
    ax_i.set_xlabel("cut length [mm] (passes of 150 mm)")
    fig.suptitle(
        "Tai et al. end milling under constant load (PI, 0.24 A): edges to the tool change",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def main() -> None:
    """Write mill_pi.png, mill_fuzzy.png, mill_corrective.png and mill_edge_life.png."""
    IMG.mkdir(parents=True, exist_ok=True)
    for name in TITLES:
        fig = _case1_figure(name, run_case1(name, seed=SEED))
        fig.savefig(IMG / f"mill_{name}.png", dpi=90)
        plt.close(fig)
    fig = _edge_life_figure()
    fig.savefig(IMG / "mill_edge_life.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
