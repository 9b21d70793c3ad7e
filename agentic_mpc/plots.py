"""Figures people would rather look at than read: bird's-eye trajectories over the road (the paper's Figures
3 and 4, colours by variant) with zoomed panels where things happen (:mod:`agentic_mpc.plot_panels`: around
each stopped car, where the ambulance passes, the agent's tool calls and the ego's manoeuvres, vehicles drawn
as their footprints), speed and lateral offset over time with the agent's tool calls marked, and the
ambulance's distance to the ego. One run's ``trajectory.png`` (:func:`run_figure`), a batch's figures per
scenario (:func:`batch_figures`) and the obstacle demo's (:func:`birds_eye`, :func:`time_series`).

Roads come from a lanes source: any object whose ``lanes()`` returns a
:class:`~agentic_mpc.world.lanes.RoadLanes` (every world, or what ``agentic-mpc plot`` rebuilds of one).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.patches import Circle as CirclePatch

from agentic_mpc.geometry import LanePath
from agentic_mpc.plot_zoom import RunFiles, read_run, zoom_windows
from agentic_mpc.plot_zoom import ambulance_distance as _ambulance_distance
from agentic_mpc.plot_zoom import tool_calls as _tool_calls
from agentic_mpc.primitives import Circle

VARIANT_COLOURS = {"no_message": "0.35", "unaware": "0.35", "message_right": "tab:red", "message_left": "tab:blue",
                   "yield": "tab:red", "observation_messages": "tab:red"}
"""The paper's figures: grey without a message, red for "from the right" (or yielding), blue for "from the left"."""
PALETTE = ("tab:green", "tab:orange", "tab:purple", "tab:brown", "tab:cyan", "tab:olive")
"""The other variants, in the order they come."""
DEFAULT_LANE_WIDTH_M = 3.5
"""The lane width when a road has a single lane to measure it from."""


def colour_of(variant: str, variants: Sequence[str]) -> str:
    """``variant``'s colour among ``variants``: the paper's if it has one, else the next in :data:`PALETTE`."""
    if variant in VARIANT_COLOURS:
        return VARIANT_COLOURS[variant]
    others = [v for v in variants if v not in VARIANT_COLOURS]
    return PALETTE[others.index(variant) % len(PALETTE)] if variant in others else PALETTE[0]


def _lanes_of(source: Any) -> list[LanePath]:
    """The lane centre lines of a lanes source (anything with ``lanes()``), none for None."""
    return [] if source is None else list(source.lanes().lanes.values())


def _draw_road(ax: Any, lanes: Sequence[LanePath], lane_width_m: float | None = None) -> None:
    """Lane centre lines (dashed, light) and the road's edges: the outermost lanes shifted outwards by half a
    lane width (by default the distance between adjacent centre lines at their first points)."""
    if not lanes:
        return
    first = np.array([lane.coordinates[0] for lane in lanes])
    offsets = lanes[0].lateral_offset(first[:, 0], first[:, 1])  # + left: orders the lanes across the road
    order = np.argsort(offsets)
    if lane_width_m is None:
        gaps = np.diff(offsets[order])
        gaps = gaps[gaps > 1e-6]
        lane_width_m = float(gaps.min()) if gaps.size else DEFAULT_LANE_WIDTH_M
    for lane in lanes:
        xy = lane.coordinates
        ax.plot(xy[:, 0], xy[:, 1], color="0.82", lw=0.8, ls="--", zorder=0)
    for lane, side in ((lanes[order[-1]], 0.5), (lanes[order[0]], -0.5)):
        xy = lane.parallel(side * lane_width_m, name="road edge").coordinates
        ax.plot(xy[:, 0], xy[:, 1], color="0.45", lw=1.0, zorder=0)


def _draw_obstacles(ax: Any, circles: Iterable[tuple[float, float, float]]) -> None:
    for x, y, r in circles:
        ax.add_patch(CirclePatch((x, y), r, color="k", alpha=0.35, zorder=1))


def _mark_events(axes: Sequence[Any], marks: Iterable[tuple[float, str]]) -> None:
    """Vertical lines at the marks' times on every axis, labelled on the first."""
    for at, label in marks:
        for ax in axes:
            ax.axvline(at, color="tab:green", lw=0.8, ls="--")
        axes[0].annotate(label, (at, axes[0].get_ylim()[1]), fontsize=7, rotation=90, va="top", ha="right",
                         color="tab:green")


def _save(fig: Any, path: Path, dpi: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _places_figure(rows: dict[str, list[RunFiles]], colours: dict[str, str], lanes: Sequence[LanePath],
                   title: str, series_rows: int = 0, width_in: float = 13.0) -> tuple[Any, Any, list[Any]]:
    """A figure with ``title``, the overview and zoomed panels of ``rows`` (variant: runs) and, below, a
    grid of ``series_rows`` time-series rows (None without). A fixed layout: no layout engine to run.
    Returns (figure, that grid, the windows)."""
    from agentic_mpc.plot_panels import draw_places, places_layout, road_lines

    road = road_lines(list(lanes))
    runs = [run for variant_runs in rows.values() for run in variant_runs]
    windows = zoom_windows(runs, road["edges"] or None)
    layout = places_layout(windows, road, runs, len(rows), width_in)
    series_in = 2.0 * series_rows + 0.6 if series_rows else 0.0
    height = 0.45 + layout["height"] + series_in
    fig = plt.figure(figsize=(width_in, height))
    fig.suptitle(title, fontsize=11, y=1 - 0.1 / height, va="top")
    draw_places(fig, 0.45, rows, colours, road, windows, layout)
    grid = None
    if series_rows:
        grid = fig.add_gridspec(series_rows, 1, left=0.8 / width_in, right=1 - 0.8 / width_in, hspace=0.3,
                                top=1 - (0.45 + layout["height"] + 0.2) / height, bottom=0.5 / height)
    return fig, grid, windows


def run_figure(out_dir: Path, world: Any, metrics: Any, title: str = "") -> Path:
    """``trajectory.png`` of one run in ``out_dir`` (from its trajectory, traffic and events CSV files):
    bird's-eye overview over ``world``'s lanes and ``metrics``' obstacles with zoomed panels where things
    happen, speed with the ambulance's distance, lateral offset, acceleration with the MPPI effective sample
    size, the agent's tool calls and the panels' moments marked."""
    out_dir = Path(out_dir)
    obstacles = [(track.id, np.array([[c.x_m, c.y_m, c.radius_m] for c in track.circles]))
                 for track in metrics.obstacles if track.circles]
    run = read_run(out_dir, obstacles)
    trajectory, traffic = run.trajectory, run.traffic
    fig, grid, windows = _places_figure({"ego path": [run]}, {"ego path": "#16a34a"}, _lanes_of(world), title,
                                        series_rows=3)
    ax_v, ax_y, ax_a = (fig.add_subplot(grid[i]) for i in range(3))
    ax_y.sharex(ax_v)
    ax_a.sharex(ax_v)
    ax_v.plot(trajectory["time_s"], trajectory["v_mps"], color="tab:blue", label="speed")
    if "v_ref_mps" in trajectory:
        ax_v.plot(trajectory["time_s"], trajectory["v_ref_mps"], color="k", lw=0.8, ls=":", label="v_ref")
    ax_v.set_ylabel("speed [m/s]")
    distance = _ambulance_distance(trajectory, traffic)
    if not distance.empty:
        ax_d = ax_v.twinx()
        for vehicle_id, track in distance.groupby("id"):
            ax_d.plot(track["time_s"], track["distance_m"], color="tab:red", lw=0.8, ls="--", label=f"{vehicle_id} distance")
        ax_d.axhline(0, color="tab:red", lw=0.4)
        ax_d.set_ylabel("ambulance - ego [m]", color="tab:red")
    if "tracked_lane_offset_m" in trajectory:
        ax_y.plot(trajectory["time_s"], trajectory["tracked_lane_offset_m"], color="tab:blue", label="from tracked lane")
    if "lateral_offset_m" in trajectory:
        ax_y.plot(trajectory["time_s"], trajectory["lateral_offset_m"], color="0.6", lw=0.8, label="from current lane")
    ax_y.set_ylabel("lateral offset [m]")
    ax_y.legend(fontsize=8, loc="upper right")
    _acceleration_and_ess(ax_a, trajectory)
    ax_a.set_xlabel("time [s]")
    _mark_events([ax_v, ax_y, ax_a], _tool_calls(run.events))
    _mark_panels(ax_v, run, windows)
    return _save(fig, out_dir / "trajectory.png", dpi=110)


def _mark_panels(ax: Any, run: RunFiles, windows: list[Any]) -> None:
    """The moments the zoomed panels show, as numbered ticks along the top of ``ax``."""
    from agentic_mpc.plot_zoom import snapshot_time

    for number, window in enumerate(windows, 1):
        at = snapshot_time(run, window)
        if at is not None:
            ax.annotate(f"[{number}]", (at, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 2),
                        textcoords="offset points", ha="center", va="bottom", fontsize=8, fontweight="bold")
            ax.axvline(at, color="k", lw=0.6, alpha=0.5)


def _acceleration_and_ess(ax: Any, trajectory: pd.DataFrame) -> None:
    """Acceleration (what the passenger feels) and, on a second axis, the MPPI effective sample size as a
    share of S (how many samples carry the average: solver health)."""
    if "accel_mps2" in trajectory:
        ax.plot(trajectory["time_s"], trajectory["accel_mps2"], color="tab:blue", lw=0.8, label="acceleration")
    ax.axhline(0, color="0.6", lw=0.4)
    ax.set_ylabel("acceleration [m/s$^2$]")
    if "effective_fraction" in trajectory:
        ax_ess = ax.twinx()
        ax_ess.plot(trajectory["time_s"], 100 * trajectory["effective_fraction"], color="tab:green", lw=0.6,
                    alpha=0.7)
        ax_ess.set_ylim(0, 100)
        ax_ess.set_ylabel("ESS [% of S]", color="tab:green")


def batch_figures(batch_dir: Path, road_of: Callable[[Path], Any]) -> list[Path]:
    """Per scenario of a batch: all trials' trajectories over the road, colours by variant
    (``<scenario>_trajectories.png``), and their speed, offset and ambulance distance over time
    (``<scenario>_timeseries.png``).

    ``road_of(scenario_json_path)`` gives a lanes source for the road a run used (rebuilt from its saved
    scenario), or None to draw no road.
    """
    batch_dir = Path(batch_dir)
    written = []
    for scenario_dir in sorted(p for p in (batch_dir / "runs").iterdir() if p.is_dir()):
        runs = sorted(scenario_dir.glob("*/seed-*/trajectory.csv"))
        if not runs:
            continue
        variants = sorted({r.parent.parent.name for r in runs})
        colours = {variant: colour_of(variant, variants) for variant in variants}
        rows: dict[str, list[RunFiles]] = {variant: [] for variant in variants}
        labelled: set[str] = set()
        fig_t, (ax_v, ax_y, ax_a, ax_d) = plt.subplots(4, 1, figsize=(11, 10), sharex=True)
        for run in runs:
            variant = run.parent.parent.name
            colour = colours[variant]
            label = None if variant in labelled else variant
            labelled.add(variant)
            files = read_run(run.parent, variant=variant)
            rows[variant].append(files)
            trajectory = files.trajectory
            ax_v.plot(trajectory["time_s"], trajectory["v_mps"], color=colour, lw=0.8, alpha=0.8, label=label)
            ax_y.plot(trajectory["time_s"], trajectory["tracked_lane_offset_m"], color=colour, lw=0.8, alpha=0.8)
            if "accel_mps2" in trajectory:
                ax_a.plot(trajectory["time_s"], trajectory["accel_mps2"], color=colour, lw=0.6, alpha=0.8)
            for _, track in _ambulance_distance(trajectory, files.traffic).groupby("id"):
                ax_d.plot(track["time_s"], track["distance_m"], color=colour, lw=0.8, alpha=0.8)
        title = (f"{scenario_dir.name}: {len(runs)} runs, colours by variant; the vehicles of each variant's "
                 "first run at the moment shown")
        fig, _, _ = _places_figure(rows, colours, _lanes_of(road_of(runs[0].parent / "scenario.json")), title)
        path = _save(fig, batch_dir / f"{scenario_dir.name}_trajectories.png", dpi=110)
        ax_v.set_ylabel("speed [m/s]")
        ax_y.set_ylabel("offset from tracked lane [m]")
        ax_a.set_ylabel("acceleration [m/s$^2$]")
        ax_d.set_ylabel("ambulance - ego [m]")
        ax_d.set_xlabel("time [s]")
        ax_v.legend(fontsize=8)
        fig_t.tight_layout()
        written += [path, _save(fig_t, batch_dir / f"{scenario_dir.name}_timeseries.png", dpi=110)]
    return written


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
    from agentic_mpc.plot_panels import footprint

    fig, ax = plt.subplots(figsize=(10, 3.6))
    _draw_road(ax, list(lanes), lane_width_m)
    _draw_obstacles(ax, [(o.x_m, o.y_m, o.radius_m) for o in obstacles])
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
    return _save(fig, path, dpi=130)


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
    _mark_events([ax_v, ax_y], events_s)
    ax_v.set_ylabel("speed [m/s]")
    ax_y.set_ylabel("lateral offset [m] (+ left)")
    ax_y.set_xlabel("time [s]")
    ax_v.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path, dpi=130)
