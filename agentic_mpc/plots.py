"""Figures people would rather look at than read: bird's-eye trajectories and time series."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle as CirclePatch  # noqa: E402

from agentic_mpc.geometry import LanePath  # noqa: E402
from agentic_mpc.primitives import Circle  # noqa: E402

VARIANT_COLOURS = {"no_message": "0.35", "message_right": "tab:red", "message_left": "tab:blue"}


def birds_eye(
    trajectories: Mapping[str, Sequence[np.ndarray]],
    lanes: Sequence[LanePath],
    obstacles: Sequence[Circle],
    path: Path,
    title: str = "",
    lane_width_m: float = 3.5,
    x_range_m: tuple[float, float] | None = None,
) -> Path:
    """Trajectories (each an (N, >=2) array of x, y) of every variant over lanes and obstacles."""
    fig, ax = plt.subplots(figsize=(10, 3.6))
    for lane in lanes:
        xy = lane.coordinates
        ax.plot(xy[:, 0], xy[:, 1], color="0.8", lw=1, ls="--", zorder=0)
        for side in (-0.5, 0.5):
            edge = lane.parallel(side * lane_width_m).coordinates
            ax.plot(edge[:, 0], edge[:, 1], color="0.6", lw=0.6, zorder=0)
    for obstacle in obstacles:
        ax.add_patch(CirclePatch((obstacle.x_m, obstacle.y_m), obstacle.radius_m, color="k", alpha=0.6, zorder=1))
    for variant, runs in trajectories.items():
        colour = VARIANT_COLOURS.get(variant)
        for i, states in enumerate(runs):
            ax.plot(states[:, 0], states[:, 1], color=colour, lw=1, alpha=0.8, label=variant if i == 0 else None)
    if x_range_m:  # a window along a straight road: keep the lanes, not the whole road, in view
        ax.set_xlim(*x_range_m)
        lane_y = np.concatenate([lane.coordinates[:, 1] for lane in lanes])
        ax.set_ylim(lane_y.min() - 1.5 * lane_width_m, lane_y.max() + 1.5 * lane_width_m)
        ax.set_aspect("equal", adjustable="box")
    else:
        ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def time_series(
    series: Mapping[str, Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]],
    path: Path,
    v_ref_mps: float | None = None,
    events_s: Sequence[tuple[float, str]] = (),
) -> Path:
    """Speed and lateral offset over time; ``series[variant]`` = [(time_s, speed_mps, lateral_m), ...]."""
    fig, (ax_v, ax_y) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    for variant, runs in series.items():
        colour = VARIANT_COLOURS.get(variant)
        for i, (t, v, lateral) in enumerate(runs):
            label = variant if i == 0 else None
            ax_v.plot(t, v, color=colour, lw=0.8, alpha=0.8, label=label)
            ax_y.plot(t, lateral, color=colour, lw=0.8, alpha=0.8)
    if v_ref_mps is not None:
        ax_v.axhline(v_ref_mps, color="k", lw=0.6, ls=":")
    for time_s, label in events_s:
        for ax in (ax_v, ax_y):
            ax.axvline(time_s, color="tab:green", lw=0.8, ls="--")
        ax_v.annotate(label, (time_s, ax_v.get_ylim()[1]), fontsize=7, rotation=90, va="top", ha="right")
    ax_v.set_ylabel("speed [m/s]")
    ax_y.set_ylabel("lateral offset [m] (+ left)")
    ax_y.set_xlabel("time [s]")
    ax_v.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
