"""The obstacle demo's figures (``agentic-mpc demo``): every variant's trajectories over the road around the
obstacle (the paper's Figure 3, :func:`birds_eye`) and speed and lateral offset over time (:func:`time_series`),
from states in memory rather than a run directory."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.patches import Circle as CirclePatch

from agentic_mpc.geometry import LanePath
from agentic_mpc.plots.drawing import colour_of, footprint, mark_events, plt, road_lines, save
from agentic_mpc.primitives import Circle


def _draw_lanes(ax: Any, lanes: Sequence[LanePath], lane_width_m: float | None = None) -> None:
    """Lane centre lines (dashed, light) and the road's edges (:func:`~agentic_mpc.plots.drawing.road_lines`)."""
    road = road_lines(lanes, lane_width_m)
    for xy in road["centres"]:
        ax.plot(xy[:, 0], xy[:, 1], color="0.82", lw=0.8, ls="--", zorder=0)
    for xy in road["edges"]:
        ax.plot(xy[:, 0], xy[:, 1], color="0.45", lw=1.0, zorder=0)


def birds_eye(
    trajectories: Mapping[str, Sequence[np.ndarray]],
    lanes: Sequence[LanePath],
    obstacles: Sequence[Circle],
    path: Path,
    title: str = "",
    lane_width_m: float = 3.5,
    x_range_m: tuple[float, float] | None = None,
) -> Path:
    """Trajectories (each an (N, >=2) array of x, y[, heading]) of every variant over lanes and obstacles.
    Without ``x_range_m`` the view zooms to the obstacles (45 m before the first to 30 m after the last).
    Where the states have a heading, each variant's first run is drawn as its footprint where it comes
    closest to the first obstacle."""
    fig, ax = plt.subplots(figsize=(10, 3.6))
    _draw_lanes(ax, list(lanes), lane_width_m)
    for o in obstacles:
        ax.add_patch(CirclePatch((o.x_m, o.y_m), o.radius_m, color="k", alpha=0.35, zorder=1))
    for variant, runs in trajectories.items():
        colour = colour_of(variant, list(trajectories))
        for i, states in enumerate(runs):
            ax.plot(states[:, 0], states[:, 1], color=colour, lw=1, alpha=0.8, label=variant if i == 0 else None)
        if runs and obstacles and runs[0].shape[1] >= 3:
            states = runs[0]
            k = int(np.argmin(np.hypot(states[:, 0] - obstacles[0].x_m, states[:, 1] - obstacles[0].y_m)))
            for patch in footprint(ax, lambda xy: xy, *states[k, :3], 4.5, 1.8, "ego", alpha=0.55):
                patch.set_edgecolor(colour)
    if x_range_m is None and obstacles:
        x_range_m = (min(o.x_m for o in obstacles) - 45.0, max(o.x_m for o in obstacles) + 30.0)
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
    return save(fig, path, dpi=130)


def time_series(
    series: Mapping[str, Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]],
    path: Path,
    v_ref_mps: float | None = None,
    events_s: Sequence[tuple[float, str]] = (),
) -> Path:
    """Speed and lateral offset over time; ``series[variant]`` = [(time_s, speed_mps, lateral_m), ...]."""
    fig, (ax_v, ax_y) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    for variant, runs in series.items():
        colour = colour_of(variant, list(series))
        for i, (t, v, lateral) in enumerate(runs):
            ax_v.plot(t, v, color=colour, lw=0.8, alpha=0.8, label=variant if i == 0 else None)
            ax_y.plot(t, lateral, color=colour, lw=0.8, alpha=0.8)
    if v_ref_mps is not None:
        ax_v.axhline(v_ref_mps, color="k", lw=0.6, ls=":")
    mark_events([ax_v, ax_y], events_s)
    ax_v.set_ylabel("speed [m/s]")
    ax_y.set_ylabel("lateral offset [m] (+ left)")
    ax_y.set_xlabel("time [s]")
    ax_v.legend(fontsize=8)
    fig.tight_layout()
    return save(fig, path, dpi=130)
