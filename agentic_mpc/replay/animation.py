"""A run as a short animated GIF (or MP4): the bird's-eye view following the ego, at a few frames a second.

The frames come from the replay's scene (:func:`agentic_mpc.replay.data.load_run`), drawn as the figures draw
(:mod:`agentic_mpc.plots.drawing`): the road's lanes, lane boundaries and edges, every vehicle's footprint
coloured by class, the stopped cars and J2's discs, on a SUMO network the streets and junctions around the road
and the stop lines in their lights' colours; then the MPPI plan where the run recorded one, the time,
speed and the latest caption (the passenger's message, an observation, a tool call). GIFs are written with
Pillow; MP4 needs ffmpeg on PATH (:class:`MissingToolError` otherwise).
"""

from __future__ import annotations

import bisect
import math
import shutil
from pathlib import Path
from typing import Any

from agentic_mpc.replay.data import load_run

FPS = 10.0
VIEW_M = 70.0
"""How much road a frame shows ahead and behind (its width, metres)."""
CAPTION_S = 4.0
"""How long a caption stays in the frame."""


class MissingToolError(RuntimeError):
    """The writer for the format needs a program that is not installed (``tool``)."""

    def __init__(self, tool: str, fmt: str) -> None:
        super().__init__(f"writing {fmt} needs {tool} on PATH, and it was not found (install {tool}, or use --gif)")
        self.tool = tool


def frame_times(scene: dict[str, Any], fps: float = FPS) -> list[float]:
    """The times of the frames: from the run's first step to its last, ``fps`` a second."""
    track = scene["ego"]["track"]
    start, end = track[0][0], track[-1][0]
    return [start + i / fps for i in range(math.floor((end - start) * fps + 1e-9) + 1)]


def _at(rows: list[list[Any]], t: float) -> Any:
    """The row of ``rows`` (sorted by their first item, the time) last at or before ``t``."""
    i = bisect.bisect_right([r[0] for r in rows], t) - 1 if rows else -1
    return rows[max(i, 0)] if rows else None


def write_animation(directory: Path, out: Path, fps: float = FPS, view_m: float = VIEW_M, dpi: int = 80) -> int:
    """Write the run in ``directory`` to ``out`` (.gif with Pillow, .mp4 with ffmpeg); returns the frame count.
    Raises :class:`~agentic_mpc.replay.data.ReplayInputError` for a non-run, :class:`MissingToolError`
    when ``out`` is an MP4 and ffmpeg is missing."""
    out = Path(out)
    mp4 = out.suffix.lower() == ".mp4"
    if mp4 and shutil.which("ffmpeg") is None:
        raise MissingToolError("ffmpeg", "MP4")
    scene = load_run(directory)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.animation import FFMpegWriter, PillowWriter
    from matplotlib.patches import Rectangle
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    from agentic_mpc.plots.drawing import draw_network, draw_obstacles, draw_road, draw_stop_lines, footprint
    from agentic_mpc.plots.network import NetworkDrawing

    def same(xy: Any) -> Any:  # the frames keep world coordinates
        return xy

    times = frame_times(scene, fps)
    width_in, height_in = 6.4, 2.5
    fig = plt.figure(figsize=(width_in, height_in), dpi=dpi)
    box = (0.01, 0.02, 0.98, 0.86)  # a fixed layout: nothing to work out again each frame
    ax = fig.add_axes(box)
    road = scene["road"]
    if road.get("network"):
        draw_network(ax, NetworkDrawing.from_json(road["network"]), same)
    lines = {"centres": road.get("lanes", []), "boundaries": road.get("boundaries", []),
             "edges": [line for part in road.get("edges", []) for line in part]}
    draw_road(ax, {key: [np.asarray(line) for line in value] for key, value in lines.items()}, same, surface=False)
    draw_obstacles(ax, same, [(obstacle["discs"], obstacle.get("car")) for obstacle in scene["obstacles"]])
    ax.set_axis_off()  # a scale bar instead of tick labels: no text to lay out again each frame
    ax.add_artist(AnchoredSizeBar(ax.transData, 10.0, "10 m", loc="lower right", frameon=False, size_vertical=0.3,
                                  fontproperties={"size": 7}, pad=0.2, borderpad=0.3))
    ax.add_patch(Rectangle((0, 0), 1, 1, transform=ax.transAxes, fill=False, edgecolor="0.6", lw=0.8, clip_on=False))
    (plan_line,) = ax.plot([], [], color="#d946ef", lw=1.2, zorder=3.5)
    label = ax.text(0.01, 0.97, "", transform=ax.transAxes, fontsize=8, va="top", zorder=6,
                    bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": "0.7", "alpha": 0.85})
    caption = ax.text(0.01, 0.03, "", transform=ax.transAxes, fontsize=7, va="bottom", zorder=6,
                      bbox={"boxstyle": "round,pad=0.2", "facecolor": "#fef9c3", "edgecolor": "0.7", "alpha": 0.9})
    ax.set_title(scene["title"], fontsize=9)
    vehicles = scene["traffic"]["vehicles"]
    frames = scene["traffic"]["frames"]
    ego, ego_size = scene["ego"]["track"], (scene["ego"]["L"], scene["ego"]["W"])
    captions = sorted(scene["captions"], key=lambda c: c["t"])
    moving: list[Any] = []
    half_height = view_m * (box[3] * height_in) / (box[2] * width_in) / 2  # equal scales

    def draw(t: float) -> None:
        for artist in moving:
            artist.remove()
        moving.clear()
        frame = _at(frames, t)
        if frame is not None and abs(frame[0] - t) < 1.0:
            for index, x, y, heading, _ in frame[1]:
                vehicle = vehicles[index]
                if None not in (x, y, heading):
                    moving.extend(footprint(ax, same, x, y, heading, vehicle["L"], vehicle["W"],
                                            "emergency" if vehicle["em"] else "traffic"))
        row = _at(ego, t)
        x, y, heading, speed = row[1], row[2], row[3] or 0.0, row[4] or 0.0
        moving.extend(footprint(ax, same, x, y, heading, *ego_size, "ego"))
        lights = [_at(junction["changes"], t) for junction in scene.get("signals", [])]
        moving.extend(draw_stop_lines(ax, same, [(c[2], c[3], c[4], c[1]) for c in lights if c and c[0] <= t],
                                      road.get("lane_width_m", 3.5)))
        plan = _at(scene["plan"], t)
        if plan is not None and abs(plan[0] - t) < 0.5 and plan[1]:
            plan_line.set_data(*zip(*plan[1]))
        else:
            plan_line.set_data([], [])
        ax.set_xlim(x - view_m / 2, x + view_m / 2)
        ax.set_ylim(y - half_height, y + half_height)
        label.set_text(f"t = {t:.1f} s   v = {speed:.1f} m/s")
        recent = [c for c in captions if t - CAPTION_S <= c["t"] <= t]
        text = f"{recent[-1]['kind']}: {recent[-1]['text']}" if recent else ""
        caption.set_text(text if len(text) <= 95 else text[:94] + "…")
        caption.set_visible(bool(text))

    writer = FFMpegWriter(fps=fps) if mp4 else PillowWriter(fps=fps)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with writer.saving(fig, str(out), dpi):
            for t in times:
                draw(t)
                writer.grab_frame()
    finally:
        plt.close(fig)
    return len(times)
