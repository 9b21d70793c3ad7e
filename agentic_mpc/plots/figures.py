"""The figures of a run and of a batch, from their directories: one run's ``trajectory.png``
(:func:`run_figure`) and a batch's two figures per scenario (:func:`batch_figures`).

Each has the bird's-eye trajectories over the road (the paper's Figures 3 and 4, colours by variant) with
zoomed panels where things happen (:mod:`agentic_mpc.plots.panels`), and speed, lateral offset and
acceleration over time with the agent's tool calls and the ambulance's distance to the ego.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from agentic_mpc.plots.drawing import centre_lines, colour_of, mark_events, plt, road_lines, save
from agentic_mpc.plots.panels import draw_places, places_layout
from agentic_mpc.plots.places import Window, ambulance_distance, snapshot_time, tool_calls, zoom_windows
from agentic_mpc.plots.runs import PlottedRun, network_of, plotted_run
from agentic_mpc.run.files import FIGURE, TRAJECTORY
from agentic_mpc.run.reader import Obstacle


def _places_figure(rows: dict[str, list[PlottedRun]], colours: dict[str, str], lanes: Sequence[Any],
                   title: str, series_rows: int = 0, width_in: float = 13.0) -> tuple[Any, Any, list[Window]]:
    """A figure with ``title``, the overview and zoomed panels of ``rows`` (variant: runs) and, below, a
    grid of ``series_rows`` time-series rows (None without). A fixed layout: no layout engine to run.
    Returns (figure, that grid, the windows)."""
    road: dict[str, Any] = dict(road_lines(list(lanes)))
    runs = [run for variant_runs in rows.values() for run in variant_runs]
    road["network"] = network_of(runs)  # the streets and junctions around a route (None on the paper's roads)
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


def run_figure(out_dir: Path, world: Any = None, metrics: Any = None, title: str = "") -> Path:
    """``trajectory.png`` of the run in ``out_dir``: bird's-eye overview with zoomed panels where things
    happen, speed with the ambulance's distance, lateral offset, acceleration with the MPPI effective sample
    size, the agent's tool calls and the panels' moments marked.

    ``world``: a lanes source for the road (the run's world; default: the road rebuilt from its
    ``scenario.json``); ``metrics``: the recorder's, whose obstacles are drawn (default: ``obstacles.csv``'s)."""
    out_dir = Path(out_dir)
    obstacles = None if metrics is None else [
        Obstacle(track.id, tuple((c.x_m, c.y_m, c.radius_m) for c in track.circles))
        for track in metrics.obstacles if track.circles]
    run = plotted_run(out_dir, obstacles)
    trajectory, traffic = run.trajectory, run.traffic
    lanes = centre_lines(world if world is not None else run.road)
    fig, grid, windows = _places_figure({"ego path": [run]}, {"ego path": "#16a34a"}, lanes, title, series_rows=3)
    ax_v, ax_y, ax_a = (fig.add_subplot(grid[i]) for i in range(3))
    ax_y.sharex(ax_v)
    ax_a.sharex(ax_v)
    ax_v.plot(trajectory["time_s"], trajectory["v_mps"], color="tab:blue", label="speed")
    if "v_ref_mps" in trajectory:
        ax_v.plot(trajectory["time_s"], trajectory["v_ref_mps"], color="k", lw=0.8, ls=":", label="v_ref")
    ax_v.set_ylabel("speed [m/s]")
    distance = ambulance_distance(trajectory, traffic)
    if not distance.empty:
        ax_d = ax_v.twinx()
        for vehicle_id, track in distance.groupby("id"):
            ax_d.plot(track["time_s"], track["distance_m"], color="tab:red", lw=0.8, ls="--",
                      label=f"{vehicle_id} distance")
        ax_d.axhline(0, color="tab:red", lw=0.4)
        ax_d.set_ylabel("ambulance - ego [m]", color="tab:red")
    if "tracked_lane_offset_m" in trajectory:
        ax_y.plot(trajectory["time_s"], trajectory["tracked_lane_offset_m"], color="tab:blue",
                  label="from tracked lane")
    if "lateral_offset_m" in trajectory:
        ax_y.plot(trajectory["time_s"], trajectory["lateral_offset_m"], color="0.6", lw=0.8, label="from current lane")
    ax_y.set_ylabel("lateral offset [m]")
    ax_y.legend(fontsize=8, loc="upper right")
    _acceleration_and_ess(ax_a, trajectory)
    ax_a.set_xlabel("time [s]")
    mark_events([ax_v, ax_y, ax_a], tool_calls(run.events))
    _mark_panels(ax_v, run, windows)
    return save(fig, out_dir / FIGURE, dpi=110)


def _mark_panels(ax: Any, run: PlottedRun, windows: list[Window]) -> None:
    """The moments the zoomed panels show, as numbered ticks along the top of ``ax``."""
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


def batch_figures(batch_dir: Path, road_of: Callable[[Path], Any] | None = None) -> list[Path]:
    """Per scenario of a batch: all trials' trajectories over the road, colours by variant
    (``<scenario>_trajectories.png``), and their speed, offset and ambulance distance over time
    (``<scenario>_timeseries.png``).

    ``road_of(run_dir)`` gives a lanes source for the road of the scenario's first run (None: no road);
    by default the road rebuilt from that run's ``scenario.json``.
    """
    batch_dir = Path(batch_dir)
    written = []
    for scenario_dir in sorted(p for p in (batch_dir / "runs").iterdir() if p.is_dir()):
        runs = [plotted_run(t.parent, variant=t.parent.parent.name)
                for t in sorted(scenario_dir.glob(f"*/seed-*/{TRAJECTORY}"))]
        if not runs:
            continue
        variants = sorted({run.variant for run in runs})
        colours = {variant: colour_of(variant, variants) for variant in variants}
        rows: dict[str, list[PlottedRun]] = {variant: [] for variant in variants}
        labelled: set[str] = set()
        fig_t, (ax_v, ax_y, ax_a, ax_d) = plt.subplots(4, 1, figsize=(11, 10), sharex=True)
        for run in runs:
            colour = colours[run.variant]
            label = None if run.variant in labelled else run.variant
            labelled.add(run.variant)
            rows[run.variant].append(run)
            trajectory = run.trajectory
            ax_v.plot(trajectory["time_s"], trajectory["v_mps"], color=colour, lw=0.8, alpha=0.8, label=label)
            ax_y.plot(trajectory["time_s"], trajectory["tracked_lane_offset_m"], color=colour, lw=0.8, alpha=0.8)
            if "accel_mps2" in trajectory:
                ax_a.plot(trajectory["time_s"], trajectory["accel_mps2"], color=colour, lw=0.6, alpha=0.8)
            for _, track in ambulance_distance(trajectory, run.traffic).groupby("id"):
                ax_d.plot(track["time_s"], track["distance_m"], color=colour, lw=0.8, alpha=0.8)
        title = (f"{scenario_dir.name}: {len(runs)} runs, colours by variant; the vehicles of each variant's "
                 "first run at the moment shown")
        road = road_of(runs[0].directory.path) if road_of is not None else runs[0].road
        fig, _, _ = _places_figure(rows, colours, centre_lines(road), title)
        path = save(fig, batch_dir / f"{scenario_dir.name}_trajectories.png", dpi=110)
        ax_v.set_ylabel("speed [m/s]")
        ax_y.set_ylabel("offset from tracked lane [m]")
        ax_a.set_ylabel("acceleration [m/s$^2$]")
        ax_d.set_ylabel("ambulance - ego [m]")
        ax_d.set_xlabel("time [s]")
        ax_v.legend(fontsize=8)
        fig_t.tight_layout()
        written += [path, save(fig_t, batch_dir / f"{scenario_dir.name}_timeseries.png", dpi=110)]
    return written
