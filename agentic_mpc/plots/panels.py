"""Bird's-eye panels that zoom to where things happen (the places of :mod:`agentic_mpc.plots.places`).

A thin overview of the whole road with the windows numbered on it, then a row of zoomed panels per variant
(one per window): the road's surface, edges, lane lines and centre lines, every trial's path, the stopped
cars, and one trial's vehicles at one moment as their footprints (rectangles turned with their heading),
coloured by class: the ego green, traffic grey, emergency vehicles red with a blue outline (their track
dotted), stopped cars dark (:mod:`agentic_mpc.plots.drawing`: the replay's colours). On a SUMO network the other
streets and the junctions lie under the road (``road["network"]``, :mod:`agentic_mpc.plots.network`) and the
stop lines of the lights the ego met are bars in the light's colour at that moment. Each panel keeps equal
scales and has a 10 m bar.
"""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np

from agentic_mpc.plots.drawing import (
    CLASS_COLOURS,
    CLASS_LABELS,
    SIGNAL_COLOURS,
    draw_network,
    draw_obstacles,
    draw_road,
    draw_stop_lines,
    footprint,
)
from agentic_mpc.plots.places import Window, snapshot_time
from agentic_mpc.plots.runs import PlottedRun


def _draw_snapshot(ax: Any, window: Window, run: PlottedRun, t: float) -> set[str]:
    """``run``'s vehicles at time ``t``: the traffic frame nearest ``t``, emergency tracks dotted, the ego."""
    drawn = {"ego"}
    traffic = run.traffic
    if not traffic.empty:
        times = traffic["time_s"].to_numpy(dtype=float)
        nearest = times[np.argmin(np.abs(times - t))]
        reach = window.length_m / 2 + 10.0
        for vehicle_id, track in traffic[traffic["emergency"]].groupby("id"):
            xy = window.view(track[["x_m", "y_m"]].to_numpy(dtype=float))
            ax.plot(xy[:, 0], xy[:, 1], color=CLASS_COLOURS["emergency"][0], lw=1.0, ls=":", zorder=2)
        if abs(nearest - t) <= 0.5:
            for row in traffic[traffic["time_s"] == nearest].itertuples():
                u, v = window.offsets(np.array([[row.x_m, row.y_m]]))[0]
                if abs(u) > reach or not window.across[0] - 5 < v < window.across[1] + 5:
                    continue
                cls = "emergency" if row.emergency else "traffic"
                length, width = run.size_of(str(row.id), str(row.type_id), str(row.vclass))
                footprint(ax, window.view, row.x_m, row.y_m, row.heading_rad, length, width, cls)
                drawn.add(cls)
    x, y, heading = run.ego_at(t)
    footprint(ax, window.view, x, y, heading, *run.ego_size, "ego")
    ax.text(0.01, 0.97, f"t = {t:.1f} s", transform=ax.transAxes, fontsize=8, va="top", ha="left", zorder=6,
            bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": "0.7", "alpha": 0.85})
    return drawn


def draw_panel(ax: Any, window: Window, road: dict[str, Any], runs: list[PlottedRun], colour: str,
               snapshot: PlottedRun | None) -> set[str]:
    """One zoomed panel: road, every run's path in ``colour``, obstacles, ``snapshot``'s vehicles.
    Returns the classes drawn (for the legend)."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    (u0, u1), (v0, v1) = window.limits()
    if road.get("network") is not None:
        low, high = window.corners().min(axis=0) - 5.0, window.corners().max(axis=0) + 5.0
        draw_network(ax, road["network"], window.view, near=(low[0], low[1], high[0], high[1]))
    draw_road(ax, road, window.view)
    for run in runs:
        xy = window.view(run.trajectory[["x_m", "y_m"]].to_numpy(dtype=float))
        ax.plot(xy[:, 0], xy[:, 1], color=colour, lw=1.3, alpha=0.85, zorder=2.5)
    drawn = draw_obstacles(ax, window.view, runs[0].obstacle_shapes()) if runs else set()
    t = snapshot_time(snapshot, window) if snapshot is not None else None
    if snapshot is not None and t is not None:
        drawn |= _draw_snapshot(ax, window, snapshot, t)
        if draw_stop_lines(ax, window.view, snapshot.lights_at(t)):
            drawn.add("stop line")
    elif snapshot is not None:
        ax.text(0.5, 0.5, "the ego never got here", transform=ax.transAxes, ha="center", va="center", fontsize=8,
                color="0.4")
    ax.set_xlim(u0, u1)
    ax.set_ylim(v0, v1)
    ax.set_aspect("equal", adjustable="box")
    ax.tick_params(labelsize=7, length=2, pad=1)
    ax.locator_params(axis="x", nbins=6)
    ax.locator_params(axis="y", nbins=4)
    ax.add_artist(AnchoredSizeBar(ax.transData, 10.0, "10 m", loc="lower right", frameon=False, size_vertical=0.25,
                                  fontproperties={"size": 7}, pad=0.2, borderpad=0.3))
    return drawn


def panel_title(number: int, window: Window) -> str:
    lead = window.lead
    same = {e.label for e in window.events if e.kind == lead.kind} == {lead.label}
    others = sorted({e.kind for e in window.events} - {lead.kind})
    more = f"\n+ {', '.join(others)}" if others else ""
    tools = {e.label.split("(")[0] for e in window.events if e.kind == lead.kind}
    name = lead.label if same else lead.kind
    if not same and lead.kind == "tool call" and len(tools) == 1:
        name = f"{lead.kind}: {tools.pop()}(...)"
    return f"[{number}] {name}{more}"


def draw_overview(ax: Any, road: dict[str, Any], rows: dict[str, list[PlottedRun]],
                  colours: dict[str, str], windows: list[Window]) -> None:
    """The whole road, every path, the obstacles and the numbered windows, at equal scales."""
    from matplotlib.patches import Polygon

    if road.get("network") is not None:
        draw_network(ax, road["network"], np.asarray, outline_only=True)
    draw_road(ax, {**road, "boundaries": []}, np.asarray, surface=False)
    xs, ys = [], []
    for variant, runs in rows.items():
        for run in runs:
            ax.plot(run.trajectory["x_m"], run.trajectory["y_m"], color=colours[variant], lw=1, alpha=0.8)
            xs.append(run.trajectory["x_m"].to_numpy())
            ys.append(run.trajectory["y_m"].to_numpy())
    first = next((runs[0] for runs in rows.values() if runs), None)
    if first is not None:
        draw_obstacles(ax, np.asarray, first.obstacle_shapes())
    for number, window in enumerate(windows, 1):
        corners = window.corners()
        ax.add_patch(Polygon(corners, closed=True, fill=False, edgecolor="k", lw=1.1, zorder=5))
        above = number % 2 == 1  # neighbouring windows' numbers alternate above and below
        corner = corners[np.argmax(corners[:, 1])] if above else corners[np.argmin(corners[:, 1])]
        ax.annotate(str(number), corner, xytext=(0, 2 if above else -2), textcoords="offset points", ha="center",
                    va="bottom" if above else "top", fontsize=9, fontweight="bold", zorder=6)
        xs.append(corners[:, 0])
        ys.append(corners[:, 1])
    if xs:
        x, y = np.concatenate(xs), np.concatenate(ys)
        ax.set_xlim(x.min() - 8, x.max() + 8)
        ax.set_ylim(y.min() - 8, y.max() + 8)
    ax.set_aspect("equal", adjustable="box")
    ax.tick_params(labelsize=7, length=2)


LEFT_IN, RIGHT_IN, GAP_IN = 0.8, 0.25, 0.45
"""Margins of the fixed layout (inches): room for the row labels and tick labels, no layout engine to run."""


def places_layout(windows: list[Window], road: dict[str, Any], runs: list[PlottedRun], n_rows: int,
                  width_in: float) -> dict[str, Any]:
    """Sizes in inches of the overview and the panels for a figure ``width_in`` wide: one scale (inches per
    metre) for every panel, so that widths follow the windows' lengths; ``height`` is the whole block's."""
    columns = max(len(windows), 1)
    inch_per_m = (width_in - LEFT_IN - RIGHT_IN - GAP_IN * (columns - 1)) / max(sum(w.length_m for w in windows), 1.0)
    across = max((w.across[1] - w.across[0] for w in windows), default=10.0)
    points = road["edges"] + [r.trajectory[["x_m", "y_m"]].to_numpy(dtype=float) for r in runs]
    span = np.ptp(np.vstack(points), axis=0) + 16.0 if points else np.array([100.0, 10.0])
    overview = float(np.clip((width_in - LEFT_IN - RIGHT_IN) * span[1] / span[0], 0.6, 2.2))
    panel = inch_per_m * across
    rows = [(0.5 if r == 0 else 0.12) + panel + (0.5 if r == n_rows - 1 else 0.3)
            for r in range(n_rows if windows else 0)]
    return {"inch_per_m": inch_per_m, "overview": overview, "panel": panel, "rows": rows,
            "height": 0.35 + overview + 0.35 + sum(rows)}


def _axes_at(fig: Any, left_in: float, top_in: float, width_in: float, height_in: float) -> Any:
    """Axes placed in inches from the figure's top left corner."""
    fig_w, fig_h = fig.get_size_inches()
    return fig.add_axes((left_in / fig_w, 1 - (top_in + height_in) / fig_h, width_in / fig_w, height_in / fig_h))


def legend_handles(colours: dict[str, str], classes: set[str]) -> list[Any]:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = [Line2D([], [], color=colour, lw=2, label=variant) for variant, colour in colours.items()]
    for cls in ("ego", "traffic", "emergency", "stopped"):
        if cls in classes:
            fill, outline = CLASS_COLOURS[cls]
            handles.append(Patch(facecolor=fill, edgecolor=outline, label=CLASS_LABELS[cls]))
    if "stop line" in classes:
        handles.append(Patch(facecolor=SIGNAL_COLOURS["red"], edgecolor=SIGNAL_COLOURS["green"], lw=2,
                             label="stop line (its light's colour)"))
    return handles


def draw_places(fig: Any, top_in: float, rows: dict[str, list[PlottedRun]], colours: dict[str, str],
                road: dict[str, Any], windows: list[Window], layout: dict[str, Any]) -> list[Any]:
    """The overview and one row of panels per variant of ``rows``, ``top_in`` inches below the top of
    ``fig`` (sized by :func:`places_layout`); the legend goes above the overview. Returns the axes,
    overview first."""
    width_in = fig.get_size_inches()[0]
    top = top_in + 0.35
    overview = _axes_at(fig, LEFT_IN, top, width_in - LEFT_IN - RIGHT_IN, layout["overview"])
    draw_overview(overview, road, rows, colours, windows)
    top += layout["overview"] + 0.35
    axes, classes = [overview], set()
    for r, (variant, runs) in enumerate(rows.items() if windows else []):
        top += 0.5 if r == 0 else 0.12
        left = LEFT_IN
        for c, window in enumerate(windows):
            width = window.length_m * layout["inch_per_m"]
            ax = _axes_at(fig, left, top, width, layout["panel"])
            left += width + GAP_IN
            classes |= draw_panel(ax, window, road, runs, colours[variant], runs[0] if runs else None)
            if r == 0:
                ax.set_title(panel_title(c + 1, window), fontsize=9, loc="left")
            if c == 0:
                ax.set_ylabel(textwrap.fill(variant.replace("_", " "), 14), fontsize=9, color=colours[variant],
                              fontweight="bold")
            if r == len(rows) - 1:
                ax.set_xlabel("along the road [m]" if window.turned else "x [m]", fontsize=8, labelpad=1)
            axes.append(ax)
        top += layout["panel"] + (0.5 if r == len(rows) - 1 else 0.3)
    overview.legend(handles=legend_handles(colours, classes | {"ego"}), fontsize=8, ncols=min(8, len(colours) + 4),
                    loc="lower left", bbox_to_anchor=(0.0, 1.0), frameon=False, borderaxespad=0.2)
    return axes
