"""Figures of scenario runs and batches: bird's-eye trajectories over the road (the paper's Figures 3
and 4, colours by variant), speed and lateral offset over time with the agent's tool calls marked, and the
ambulance's distance to the ego."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.patches import Circle as CirclePatch  # noqa: E402

PALETTE = ("tab:green", "tab:orange", "tab:purple", "tab:brown", "tab:cyan", "tab:olive")
PAPER_COLOURS = {"no_message": "0.35", "unaware": "0.35", "message_right": "tab:red", "message_left": "tab:blue",
                 "yield": "tab:red", "observation_messages": "tab:red"}
"""The paper's figures: grey without a message, red for "from the right", blue for "from the left"."""


def _colour(variants: list[str], variant: str) -> str:
    if variant in PAPER_COLOURS:
        return PAPER_COLOURS[variant]
    others = [v for v in variants if v not in PAPER_COLOURS]
    return PALETTE[others.index(variant) % len(PALETTE)]


def _draw_road(ax: Any, road: Any) -> None:
    for path in road.lane_paths:
        xy = path.coordinates
        ax.plot(xy[:, 0], xy[:, 1], color="0.82", lw=0.8, ls="--", zorder=0)
    for edge in (road.left_edge, road.right_edge):
        xy = edge.coordinates
        ax.plot(xy[:, 0], xy[:, 1], color="0.45", lw=1.0, zorder=0)


def _draw_obstacles(ax: Any, circles: list[tuple[float, float, float]]) -> None:
    for x, y, r in circles:
        ax.add_patch(CirclePatch((x, y), r, color="k", alpha=0.35, zorder=1))


def _tool_calls(events: pd.DataFrame) -> list[tuple[float, str]]:
    if events.empty:
        return []
    calls = events[events["event"] == "tool_call"]
    marks = []
    for _, call in calls.iterrows():
        at = call["apply_at_s"] if pd.notna(call.get("apply_at_s")) else call["sim_time_s"]
        if pd.notna(at):
            marks.append((float(at), f"{call['tool']}({_short(call['arguments'])})"))
    return marks


def _short(arguments: Any) -> str:
    if not isinstance(arguments, str):
        return ""
    return arguments.strip("{}").replace('"', "").replace(" ", "")


def _ambulance_distance(trajectory: pd.DataFrame, traffic: pd.DataFrame) -> pd.DataFrame:
    """Along-road distance of each emergency vehicle from the ego (negative: behind)."""
    if traffic.empty or not traffic["emergency"].any():
        return pd.DataFrame(columns=["time_s", "id", "distance_m"])
    ambulance = traffic[traffic["emergency"]][["time_s", "id", "road_s_m"]]
    ego = trajectory[["time_s", "road_s_m"]].rename(columns={"road_s_m": "ego_s_m"})
    merged = pd.merge_asof(ambulance.sort_values("time_s"), ego.sort_values("time_s"), on="time_s")
    merged["distance_m"] = merged["road_s_m"] - merged["ego_s_m"]
    return merged


def _focus(ax: Any, frames: list[pd.DataFrame], circles: list[tuple[float, float, float]], margin_m: float = 8.0) -> None:
    """Zoom on where the ego drove, with equal scales."""
    xs = np.concatenate([f["x_m"].to_numpy() for f in frames] + [np.array([c[0] for c in circles])])
    ys = np.concatenate([f["y_m"].to_numpy() for f in frames] + [np.array([c[1] for c in circles])])
    ax.set_xlim(xs.min() - margin_m, xs.max() + margin_m)
    ax.set_ylim(ys.min() - margin_m, ys.max() + margin_m)
    ax.set_aspect("equal", adjustable="box")  # the box takes the road's shape: long and thin on a straight


def run_figure(out_dir: Path, road: Any, recorder: Any, title: str = "") -> Path:
    """``trajectory.png`` of one run: bird's-eye view, speed, lateral offset, ambulance distance."""
    out_dir = Path(out_dir)
    trajectory = pd.read_csv(out_dir / "trajectory.csv")
    traffic = pd.read_csv(out_dir / "traffic.csv")
    events = pd.read_csv(out_dir / "events.csv")
    circles = [(c.x_m, c.y_m, c.radius_m) for track in recorder.obstacles for c in track.circles]
    fig = plt.figure(figsize=(11, 7))
    grid = fig.add_gridspec(3, 1, height_ratios=[0.7, 1, 1])
    ax_map = fig.add_subplot(grid[0])
    _draw_road(ax_map, road)
    _draw_obstacles(ax_map, circles)
    ax_map.plot(trajectory["x_m"], trajectory["y_m"], color="tab:blue", lw=1.5, label="ego")
    distance = _ambulance_distance(trajectory, traffic)
    for vehicle_id, track in traffic[traffic["emergency"]].groupby("id") if not traffic.empty else []:
        ax_map.plot(track["x_m"], track["y_m"], color="tab:red", lw=1, ls=":", label=f"{vehicle_id} (emergency)")
    _focus(ax_map, [trajectory], circles)
    ax_map.set_title(title)
    ax_map.legend(loc="upper right", fontsize=8)
    ax_v = fig.add_subplot(grid[1])
    ax_v.plot(trajectory["time_s"], trajectory["v_mps"], color="tab:blue", label="speed")
    if "v_ref_mps" in trajectory:
        ax_v.plot(trajectory["time_s"], trajectory["v_ref_mps"], color="k", lw=0.8, ls=":", label="v_ref")
    ax_v.set_ylabel("speed [m/s]")
    if not distance.empty:
        ax_d = ax_v.twinx()
        for vehicle_id, track in distance.groupby("id"):
            ax_d.plot(track["time_s"], track["distance_m"], color="tab:red", lw=0.8, ls="--", label=f"{vehicle_id} distance")
        ax_d.axhline(0, color="tab:red", lw=0.4)
        ax_d.set_ylabel("ambulance - ego [m]", color="tab:red")
    ax_y = fig.add_subplot(grid[2], sharex=ax_v)
    ax_y.plot(trajectory["time_s"], trajectory["tracked_lane_offset_m"], color="tab:blue", label="from tracked lane")
    ax_y.plot(trajectory["time_s"], trajectory["lateral_offset_m"], color="0.6", lw=0.8, label="from current lane")
    ax_y.set_ylabel("lateral offset [m]")
    ax_y.set_xlabel("time [s]")
    ax_y.legend(fontsize=8, loc="upper right")
    for at, label in _tool_calls(events):
        for ax in (ax_v, ax_y):
            ax.axvline(at, color="tab:green", lw=0.8, ls="--")
        ax_v.annotate(label, (at, ax_v.get_ylim()[1]), fontsize=7, rotation=90, va="top", ha="right", color="tab:green")
    fig.tight_layout()
    path = out_dir / "trajectory.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def batch_figures(batch_dir: Path, road_of: Any) -> list[Path]:
    """Per scenario of a batch: all trials' trajectories by variant, and their speed/offset over time.

    ``road_of(scenario_json_path)`` rebuilds the road a run used (from its saved scenario).
    """
    batch_dir = Path(batch_dir)
    written = []
    for scenario_dir in sorted(p for p in (batch_dir / "runs").iterdir() if p.is_dir()):
        runs = sorted(scenario_dir.glob("*/seed-*/trajectory.csv"))
        if not runs:
            continue
        variants = sorted({r.parent.parent.name for r in runs})
        road = road_of(runs[0].parent / "scenario.json")
        fig, ax = plt.subplots(figsize=(11, 4.5), layout="constrained")
        _draw_road(ax, road)
        frames = []
        circles: list[tuple[float, float, float]] = []
        fig_t, (ax_v, ax_y, ax_d) = plt.subplots(3, 1, figsize=(11, 8), sharex=True)
        for run in runs:
            variant = run.parent.parent.name
            colour = _colour(variants, variant)
            trajectory = pd.read_csv(run)
            frames.append(trajectory)
            first = run == next(r for r in runs if r.parent.parent.name == variant)
            label = variant if first else None
            ax.plot(trajectory["x_m"], trajectory["y_m"], color=colour, lw=1, alpha=0.8, label=label)
            ax_v.plot(trajectory["time_s"], trajectory["v_mps"], color=colour, lw=0.8, alpha=0.8, label=label)
            ax_y.plot(trajectory["time_s"], trajectory["tracked_lane_offset_m"], color=colour, lw=0.8, alpha=0.8)
            traffic_file = run.parent / "traffic.csv"
            if traffic_file.exists():
                distance = _ambulance_distance(trajectory, pd.read_csv(traffic_file))
                for _, track in distance.groupby("id"):
                    ax_d.plot(track["time_s"], track["distance_m"], color=colour, lw=0.8, alpha=0.8)
            obstacles_file = run.parent / "obstacles.csv"
            if obstacles_file.exists() and not circles:
                circles = [tuple(row) for row in pd.read_csv(obstacles_file)[["x_m", "y_m", "radius_m"]].to_numpy()]
        _draw_obstacles(ax, circles)
        _focus(ax, frames, circles)
        ax.set_title(f"{scenario_dir.name}: {len(runs)} runs, colours by variant")
        ax.legend(fontsize=8, loc="upper right")
        width, height = np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim())
        fig.set_size_inches(11, float(np.clip(11 * height / width + 1.2, 2.6, 9)))  # the road's own shape
        path = batch_dir / f"{scenario_dir.name}_trajectories.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        ax_v.set_ylabel("speed [m/s]")
        ax_y.set_ylabel("offset from tracked lane [m]")
        ax_d.set_ylabel("ambulance - ego [m]")
        ax_d.set_xlabel("time [s]")
        ax_v.legend(fontsize=8)
        fig_t.tight_layout()
        path_t = batch_dir / f"{scenario_dir.name}_timeseries.png"
        fig_t.savefig(path_t, dpi=110)
        plt.close(fig_t)
        written += [path, path_t]
    return written
