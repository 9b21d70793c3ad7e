"""What every figure and the replay's animation draw with: one palette (variants, and vehicle classes as in the
replay page), the road from its lane centre lines, vehicles as their footprints, the static obstacles, event
marks on time axes, and saving a figure.

A ``view`` maps world points (n, 2) to an axes' coordinates (the identity, or a zoomed panel's turned frame).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt
import numpy as np

VARIANT_COLOURS = {"no_message": "0.35", "unaware": "0.35", "message_right": "tab:red", "message_left": "tab:blue",
                   "yield": "tab:red", "observation_messages": "tab:red"}
"""The paper's figures: grey without a message, red for "from the right" (or yielding), blue for "from the left"."""
PALETTE = ("tab:green", "tab:orange", "tab:purple", "tab:brown", "tab:cyan", "tab:olive")
"""The other variants, in the order they come."""
CLASS_COLOURS = {"ego": ("#16a34a", "#052e16"), "traffic": ("#94a3b8", "#0f172a"),
                 "emergency": ("#dc2626", "#1d4ed8"), "stopped": ("#374151", "#111827")}
"""(fill, outline) of a footprint by class, as in the replay."""
CLASS_LABELS = {"ego": "ego", "traffic": "traffic", "emergency": "emergency vehicle",
                "stopped": "stopped car / obstacle"}
SIGNAL_COLOURS = {"red": "#dc2626", "yellow": "#facc15", "green": "#22c55e", "off": "#9ca3af"}
"""A stop line's colour by its light (the replay's); an ``unobserved`` light is not drawn."""
NETWORK_FILL = "0.86"
"""The other streets and the junctions: a shade darker than the ego's road."""
DEFAULT_LANE_WIDTH_M = 3.5
"""The lane width when a road has a single lane to measure it from."""


def colour_of(variant: str, variants: Sequence[str]) -> str:
    """``variant``'s colour among ``variants``: the paper's if it has one, else the next in :data:`PALETTE`."""
    if variant in VARIANT_COLOURS:
        return VARIANT_COLOURS[variant]
    others = [v for v in variants if v not in VARIANT_COLOURS]
    return PALETTE[others.index(variant) % len(PALETTE)] if variant in others else PALETTE[0]


def centre_lines(source: Any) -> list[Any]:
    """The lane centre lines of a lanes source (anything with ``lanes()``: a world, a rebuilt road), none for None."""
    return [] if source is None else list(source.lanes().lanes.values())


def road_lines(lanes: Sequence[Any], lane_width_m: float | None = None) -> dict[str, list[np.ndarray]]:
    """Polylines of a road from its lane centre lines: ``centres``, ``boundaries`` between adjacent lanes and
    ``edges`` (left, right): the outermost lanes shifted outwards by half a lane width (by default the
    smallest distance between adjacent centre lines at their first points)."""
    if not lanes:
        return {"centres": [], "boundaries": [], "edges": []}
    first = np.array([lane.coordinates[0] for lane in lanes])
    offsets = lanes[0].lateral_offset(first[:, 0], first[:, 1])  # + left: orders the lanes across the road
    order = np.argsort(offsets)
    gaps = np.diff(offsets[order])
    if lane_width_m is None:
        real = gaps[gaps > 1e-6]
        lane_width_m = float(real.min()) if real.size else DEFAULT_LANE_WIDTH_M
    ordered = [lanes[i] for i in order]  # right to left
    boundaries = [lane.parallel(gap / 2).coordinates for lane, gap in zip(ordered[:-1], gaps) if gap > 1e-6]
    edges = [ordered[-1].parallel(lane_width_m / 2).coordinates, ordered[0].parallel(-lane_width_m / 2).coordinates]
    return {"centres": [lane.coordinates for lane in lanes], "boundaries": boundaries, "edges": edges}


def draw_road(ax: Any, road: dict[str, list[np.ndarray]], view: Any, surface: bool = True) -> None:
    """The road of :func:`road_lines`: its surface between the two edges, dotted centre lines, dashed lane
    boundaries, solid edges."""
    if surface and len(road["edges"]) == 2:
        left, right = (view(edge) for edge in road["edges"])
        ax.fill(np.r_[left[:, 0], right[::-1, 0]], np.r_[left[:, 1], right[::-1, 1]], color="0.95", lw=0, zorder=0)
    for line in road["centres"]:
        xy = view(line)
        ax.plot(xy[:, 0], xy[:, 1], color="0.8", lw=0.6, ls=":", zorder=0.2)
    for line in road["boundaries"]:
        xy = view(line)
        ax.plot(xy[:, 0], xy[:, 1], color="0.55", lw=0.8, ls=(0, (6, 6)), zorder=0.3)
    for line in road["edges"]:
        xy = view(line)
        ax.plot(xy[:, 0], xy[:, 1], color="0.3", lw=1.3, zorder=0.3)


def draw_network(ax: Any, network: Any, view: Any, near: tuple[float, float, float, float] | None = None,
                 outline_only: bool = False) -> None:
    """The streets and junctions around the ego's road (a :class:`~agentic_mpc.plots.network.NetworkDrawing`):
    their paved area filled under the road, the lines between lanes dashed; ``outline_only`` (an overview): the
    lanes' centre lines, thin. ``near`` (xmin, ymin, xmax, ymax): only what reaches into this box is drawn."""
    from matplotlib.collections import LineCollection, PolyCollection

    def reaches(points: np.ndarray) -> bool:
        if near is None:
            return True
        return bool(points[:, 0].max() >= near[0] and points[:, 0].min() <= near[2]
                    and points[:, 1].max() >= near[1] and points[:, 1].min() <= near[3])

    if outline_only:
        lines = [view(line) for _, line in network.lanes if reaches(line)]
        ax.add_collection(LineCollection(lines, colors="0.75", linewidths=0.5, zorder=0.1))
        return
    surfaces = [view(outline) for outline in network.surface_outlines if reaches(outline)]
    ax.add_collection(PolyCollection(surfaces, facecolors=NETWORK_FILL, edgecolors=NETWORK_FILL, linewidths=0.3,
                                     zorder=0))
    dividers = [view(line) for line in network.dividers if reaches(line)]
    ax.add_collection(LineCollection(dividers, colors="0.6", linewidths=0.6, linestyles=(0, (6, 6)), zorder=0.1))


def draw_stop_lines(ax: Any, view: Any, lights: Iterable[tuple[float, float, float, str]],
                    width_m: float = DEFAULT_LANE_WIDTH_M) -> list[Any]:
    """A bar across the ego's lane at each stop line (x, y, heading of the lane, its light's state), in the
    light's colour; returns the bars (an animation removes them for the next frame)."""
    from matplotlib.patches import Polygon

    drawn = []
    for x, y, heading, state in lights:
        if state not in SIGNAL_COLOURS:
            continue
        c, s = math.cos(heading), math.sin(heading)
        local = np.array([[-0.4, -width_m / 2], [0.4, -width_m / 2], [0.4, width_m / 2], [-0.4, width_m / 2]])
        corners = np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]])
        drawn.append(ax.add_patch(Polygon(view(corners), closed=True, facecolor=SIGNAL_COLOURS[state],
                                          edgecolor="0.1", lw=0.7, zorder=3.2)))
    return drawn


def footprint(ax: Any, view: Any, x: float, y: float, heading: float, length: float, width: float, cls: str,
              alpha: float = 1.0) -> list[Any]:
    """A vehicle as its rectangle turned by ``heading``, centred on (x, y), with a windscreen at the front;
    returns the two patches (an animation removes them for the next frame)."""
    from matplotlib.patches import Polygon

    fill, outline = CLASS_COLOURS[cls]
    c, s = math.cos(heading), math.sin(heading)

    def rect(u0: float, u1: float, w0: float, w1: float) -> np.ndarray:
        local = np.array([[u0, w0], [u1, w0], [u1, w1], [u0, w1]])
        return view(np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]]))

    body = rect(-length / 2, length / 2, -width / 2, width / 2)
    screen = rect(0.12 * length, 0.26 * length, -0.38 * width, 0.38 * width)
    return [ax.add_patch(Polygon(body, closed=True, facecolor=fill, edgecolor=outline, lw=1.0, alpha=alpha, zorder=4)),
            ax.add_patch(Polygon(screen, closed=True, facecolor=outline, edgecolor="none", alpha=0.55 * alpha,
                                 zorder=4.1))]


def draw_obstacles(ax: Any, view: Any, obstacles: Iterable[tuple[Sequence[Sequence[float]], Sequence[float] | None]],
                   ) -> set[str]:
    """Each obstacle's J2 discs (x, y, radius: a lone disc filled, a stopped car's dashed outlines) and the
    stopped car's footprint (``car``: x, y, heading, length, width; None without). Returns the classes drawn."""
    from matplotlib.patches import Circle

    drawn = set()
    for discs, car in obstacles:
        single = len(discs) == 1
        for x, y, radius in discs:
            (u, v), = view(np.array([[x, y]]))
            ax.add_patch(Circle((u, v), radius, facecolor=CLASS_COLOURS["stopped"][0] if single else "none",
                                alpha=0.5 if single else 0.6, edgecolor="0.2", lw=0.7, ls="-" if single else "--",
                                zorder=3))
        if car is not None:
            footprint(ax, view, *car, "stopped")
        drawn.add("stopped")
    return drawn


def mark_events(axes: Sequence[Any], marks: Iterable[tuple[float, str]]) -> None:
    """Vertical lines at the marks' times on every axis, labelled on the first."""
    for at, label in marks:
        for ax in axes:
            ax.axvline(at, color="tab:green", lw=0.8, ls="--")
        axes[0].annotate(label, (at, axes[0].get_ylim()[1]), fontsize=7, rotation=90, va="top", ha="right",
                         color="tab:green")


def save(fig: Any, path: Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` (making its directory) and close it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
