"""Where things happen on a long road, for the zoomed bird's-eye panels (:mod:`agentic_mpc.plots.panels`).

A run's *places* come from its files: each stopped car (obstacles.csv), where an ambulance passes the ego (or
where it is held up closest behind it, when it never passes), the agent's tool calls when they take effect
(events.csv), the ego's manoeuvres (lane changes, offsets over 1 m from the tracked lane) and, on a route, the
traffic lights it met (signals.csv: where it waited at red, else where it crossed the line; events.csv's red light
and right of way violations). Places within ``span_m`` of each other along the road are one :class:`Window`: a
rectangle turned with the road around them, a few tens of metres long, where the panels draw the road and every
vehicle's footprint at equal scales.

No matplotlib here: the windows are plain numbers (the tests check them without drawing).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from agentic_mpc.plots.runs import PlottedRun

KIND_RANK = {"stopped car": 0, "obstacle": 0, "ambulance passes": 1, "ambulance held up": 2, "red light": 1,
             "right of way": 1, "tool call": 3, "waiting at a light": 3, "traffic light": 4, "lane change": 4,
             "swerve": 5}
"""Which places win when there are more than fit in a row: obstacles first, manoeuvres last."""
HELD_UP_M = 60.0
"""An ambulance that never passes is a place where it comes closest behind the ego, if nearer than this."""
SWERVE_M = 1.0
"""An offset from the tracked lane above this is a manoeuvre (its peak is the place)."""
STANDING_MPS = 0.3
"""The ego waits at a light when slower than this (as the junction log counts it)."""
LIGHT_KINDS = frozenset({"waiting at a light", "traffic light", "red light", "right of way"})
JUNCTION_ACROSS_M = 24.0
"""A window at a junction is at least this wide across the road: the crossing streets show."""


@dataclass(frozen=True)
class Event:
    """A place in one run: what happened (``kind``, ``label``), when (``t``) and where (ego's road ``s``, x, y)."""

    kind: str
    label: str
    t: float
    s: float
    x: float
    y: float
    run: str
    reach_m: float = 0.0
    """How far along the road around ``s`` the place reaches (an ambulance held up behind: to it)."""


def tool_calls(events: pd.DataFrame) -> list[tuple[float, str]]:
    """(time the call took effect, ``tool(arguments)``) of each of the agent's tool calls."""
    if events.empty or "event" not in events:
        return []
    marks = []
    for _, call in events[events["event"] == "tool_call"].iterrows():
        at = call["apply_at_s"] if pd.notna(call.get("apply_at_s")) else call["sim_time_s"]
        if pd.notna(at):
            arguments = call["arguments"]
            short = arguments.strip("{}").replace('"', "").replace(" ", "") if isinstance(arguments, str) else ""
            marks.append((float(at), f"{call['tool']}({short})"))
    return marks


def ambulance_distance(trajectory: pd.DataFrame, traffic: pd.DataFrame) -> pd.DataFrame:
    """Along-road distance of each emergency vehicle from the ego (negative: behind)."""
    if traffic.empty or not traffic["emergency"].astype(bool).any() or "road_s_m" not in trajectory:
        return pd.DataFrame(columns=["time_s", "id", "distance_m"])
    ambulance = traffic[traffic["emergency"].astype(bool)][["time_s", "id", "road_s_m"]].dropna()
    ego = trajectory[["time_s", "road_s_m"]].rename(columns={"road_s_m": "ego_s_m"})
    merged = pd.merge_asof(ambulance.sort_values("time_s"), ego.sort_values("time_s"), on="time_s")
    merged["distance_m"] = merged["road_s_m"] - merged["ego_s_m"]
    return merged


def find_events(run: PlottedRun) -> list[Event]:
    """Every place of ``run``: obstacles, ambulance passes (or hold-ups), tool calls, lane changes, swerves."""
    tr = run.trajectory
    if tr.empty:
        return []
    t, s, x, y = (tr[c].to_numpy(dtype=float) for c in ("time_s", "s", "x_m", "y_m"))

    def at_time(kind: str, label: str, when: float) -> Event:
        i = int(np.clip(np.searchsorted(t, when), 0, len(t) - 1))
        return Event(kind, label, when, s[i], x[i], y[i], run.name)

    found = []
    for obstacle in run.obstacles:
        discs = np.array(obstacle.discs)
        cx, cy = discs[:, 0].mean(), discs[:, 1].mean()
        i = int(np.argmin(np.hypot(x - cx, y - cy)))  # where the ego comes alongside
        kind = "stopped car" if len(discs) > 1 else "obstacle"
        label = kind if obstacle.id in ("obstacle", "", "nan") else f"{kind} {obstacle.id}"
        found.append(Event(kind, label, t[i], s[i], float(cx), float(cy), run.name))
    for vehicle_id, track in ambulance_distance(tr, run.traffic).groupby("id"):
        d = track["distance_m"].to_numpy(dtype=float)
        passes = np.flatnonzero((d[:-1] < 0) & (d[1:] >= 0))
        for i in passes:
            found.append(at_time("ambulance passes", f"{vehicle_id} passes", float(track["time_s"].iloc[i + 1])))
        behind = np.where(d < 0, d, -np.inf)
        if not passes.size and behind.size and behind.max() > -HELD_UP_M:
            i = int(np.argmax(behind))
            label = f"{vehicle_id} held up {-d[i]:.0f} m behind"
            event = at_time("ambulance held up", label, float(track["time_s"].iloc[i]))
            found.append(Event(event.kind, event.label, event.t, event.s + d[i] / 2, event.x, event.y, run.name,
                               -d[i] / 2 + 4.0))
    for when, label in tool_calls(run.events):
        found.append(at_time("tool call", label, when))
    found += light_events(run, at_time)
    if not run.events.empty and "event" in run.events:
        names = {"red_light_violation": "red light", "right_of_way_violation": "right of way"}
        for row in run.events[run.events["event"].isin(list(names))].itertuples():
            label = f"{names[row.event]} violation: {_short(str(row.content))}"
            found.append(at_time(names[row.event], label, float(row.sim_time_s)))
    if "lane_index" in tr:
        lane = tr["lane_index"].to_numpy(dtype=float)
        for i in np.flatnonzero(np.isfinite(lane[:-1]) & np.isfinite(lane[1:]) & (np.diff(lane) != 0)):
            found.append(Event("lane change", f"lane {lane[i]:.0f} to {lane[i + 1]:.0f}", t[i + 1], s[i + 1],
                               x[i + 1], y[i + 1], run.name))
    if "tracked_lane_offset_m" in tr:
        offset = np.nan_to_num(tr["tracked_lane_offset_m"].to_numpy(dtype=float))
        wide = np.abs(offset) > SWERVE_M
        starts = np.flatnonzero(wide & ~np.concatenate([[False], wide[:-1]]))
        for start in starts:
            stop = start + int(np.argmin(wide[start:])) if not wide[start:].all() else len(wide)
            i = start + int(np.argmax(np.abs(offset[start:stop])))
            found.append(Event("swerve", f"offset {offset[i]:+.1f} m", t[i], s[i], x[i], y[i], run.name))
    return found


def light_events(run: PlottedRun, at_time: Callable[[str, str, float], Event]) -> list[Event]:
    """One place per traffic light the ego met (``signals.csv``): where it first stood at the light's red or
    yellow (reaching to the stop line ahead of it), else where its centre came closest to the stop line."""
    if run.signals.empty:
        return []
    tr = run.trajectory
    t, s, v = (tr[c].to_numpy(dtype=float) for c in ("time_s", "s", "v_mps"))
    xy = tr[["x_m", "y_m"]].to_numpy(dtype=float)
    found = []
    stops = run.signals.groupby("junction_id", sort=False)["stop_s_m"].first().to_numpy(dtype=float)
    for junction_id, rows in run.signals.groupby("junction_id", sort=False):
        line = rows[["x_m", "y_m"]].to_numpy(dtype=float)[0]
        stop_s = float(rows["stop_s_m"].iloc[0])
        name = _short(str(junction_id))
        times, states = rows["time_s"].to_numpy(dtype=float), rows["state"].astype(str).to_numpy()
        state_now = np.searchsorted(times, t, side="right") - 1  # the row in force at each step
        stopping = np.isin(states[np.clip(state_now, 0, None)], ["red", "yellow"]) & (state_now >= 0)
        nearest = np.all(s[:, None] >= stops[None, stops < stop_s], axis=1)  # no other light's line in between
        waiting = np.flatnonzero(stopping & nearest & (v < STANDING_MPS) & (s < stop_s))
        if waiting.size:
            i = waiting[0]
            event = at_time("waiting at a light", f"waiting at a light: {name}", float(t[i]))
            reach = (stop_s - s[i]) / 2
            found.append(Event(event.kind, event.label, event.t, s[i] + reach, event.x, event.y, run.name,
                               reach + 4.0))
        else:
            i = int(np.argmin(np.hypot(*(xy - line).T)))
            state = states[max(state_now[i], 0)]
            found.append(at_time("traffic light", f"{state} light: {name}", float(t[i])))
    return found


def _short(junction_id: str, chars: int = 12) -> str:
    """A junction's id as a panel title shows it (an OpenStreetMap cluster's id lists every node it joins)."""
    return junction_id if len(junction_id) <= chars else junction_id[: chars - 1] + "…"


@dataclass(frozen=True)
class Window:
    """A rectangle turned with the road: ``length_m`` along it (centred on ``centre``), ``across`` = (min, max)
    sideways (+ left), and the places inside. On a road along +x the view keeps world coordinates."""

    centre: tuple[float, float]
    heading_rad: float
    length_m: float
    across: tuple[float, float]
    s_m: float
    events: tuple[Event, ...]

    @property
    def lead(self) -> Event:
        """The place that names the window (the highest ranked, then the earliest)."""
        return min(self.events, key=lambda e: (KIND_RANK.get(e.kind, 9), e.t))

    @property
    def turned(self) -> bool:
        return self.heading_rad != 0.0

    def offsets(self, xy: np.ndarray) -> np.ndarray:
        """World points (n, 2) as (along, across) the window's direction from its centre."""
        d = np.asarray(xy, dtype=float).reshape(-1, 2) - np.asarray(self.centre)
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])

    def view(self, xy: np.ndarray) -> np.ndarray:
        """World points (n, 2) in the panel's coordinates: world x, y on a road along +x, else :meth:`offsets`."""
        return self.offsets(xy) if self.turned else np.asarray(xy, dtype=float).reshape(-1, 2).copy()

    def limits(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((u0, u1), (v0, v1)) of the panel, in its coordinates."""
        ox, oy = (0.0, 0.0) if self.turned else self.centre
        half = self.length_m / 2
        return (ox - half, ox + half), (oy + self.across[0], oy + self.across[1])

    def corners(self) -> np.ndarray:
        """The window's four corners in world coordinates (for the overview)."""
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        half = self.length_m / 2
        low, high = self.across
        local = np.array([[-half, low], [half, low], [half, high], [-half, high]])
        turned = np.column_stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]])
        return np.asarray(self.centre) + turned

    def contains(self, x: float, y: float) -> bool:
        u, v = self.offsets(np.array([[x, y]]))[0]
        return abs(u) <= self.length_m / 2 and self.across[0] <= v <= self.across[1]


def _densify(line: np.ndarray, step_m: float = 2.0) -> np.ndarray:
    """A polyline's points every ``step_m`` (a straight edge has only its two ends)."""
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    at = np.arange(0.0, along[-1] + step_m, step_m).clip(max=along[-1])
    return np.column_stack([np.interp(at, along, line[:, 0]), np.interp(at, along, line[:, 1])])


def _chord(line: np.ndarray, near: np.ndarray, half_m: float) -> tuple[np.ndarray, float]:
    """The point of a dense polyline nearest ``near`` and the direction of its chord over +-``half_m``."""
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    i = int(np.argmin(np.hypot(*(line - near).T)))
    a = np.array([np.interp(along[i] - half_m, along, line[:, k]) for k in (0, 1)])
    b = np.array([np.interp(along[i] + half_m, along, line[:, k]) for k in (0, 1)])
    return line[i], math.atan2(b[1] - a[1], b[0] - a[0])


def _ego_point(runs: list[PlottedRun], s: float) -> np.ndarray | None:
    """The ego's position at road position ``s`` in the first run that drove there."""
    for run in runs:
        along = np.maximum.accumulate(run.trajectory["s"].to_numpy(dtype=float))
        if along[0] - 1.0 <= s <= along[-1] + 1.0:
            i = int(np.clip(np.searchsorted(along, s), 0, len(along) - 1))
            return run.trajectory[["x_m", "y_m"]].to_numpy(dtype=float)[i]
    return None


def zoom_windows(runs: list[PlottedRun], edges: list[np.ndarray] | None = None, max_windows: int = 4,
                 span_m: float = 40.0, pad_m: float = 12.0, min_length_m: float = 40.0) -> list[Window]:
    """The windows around the places of ``runs`` (one road), at most ``max_windows`` (highest ranked kept),
    in order along the road. ``edges``: the road's two edge polylines (the windows follow the road's middle
    and direction; without them, the ego's path)."""
    events = sorted((e for run in runs for e in find_events(run)), key=lambda e: (e.s, e.t))
    clusters: list[list[Event]] = []
    for event in events:
        if clusters and event.s - clusters[-1][0].s <= span_m:
            clusters[-1].append(event)
        else:
            clusters.append([event])
    clusters.sort(key=lambda c: (min(KIND_RANK.get(e.kind, 9) for e in c), c[0].s))
    dense = [_densify(np.asarray(e, dtype=float)) for e in (edges or []) if len(e) > 1]
    paths = [_densify(r.trajectory[["x_m", "y_m"]].to_numpy(dtype=float), 1.0) for r in runs if len(r.trajectory) > 1]
    windows = []
    for cluster in sorted(clusters[:max_windows], key=lambda c: c[0].s):
        s0 = min(e.s - e.reach_m for e in cluster) - pad_m
        s1 = max(e.s + e.reach_m for e in cluster) + pad_m
        length = max(s1 - s0, min_length_m)
        s_mid = (s0 + s1) / 2
        near = _ego_point(runs, s_mid)
        if near is None:
            near = np.array([cluster[0].x, cluster[0].y])
        if len(dense) == 2:
            (a, heading), (b, _) = _chord(dense[0], near, length / 2), _chord(dense[1], near, length / 2)
            centre = (a + b) / 2  # the road's middle
        else:
            centre, heading = _chord(paths[0], near, length / 2) if paths else (near, 0.0)
        if abs(math.remainder(heading, 2 * math.pi)) < math.radians(1.0):
            heading = 0.0
        window = Window((float(centre[0]), float(centre[1])), heading, length, (-1.0, 1.0), s_mid, tuple(cluster))
        windows.append(_fit_across(window, dense + paths, [np.array(o.discs) for r in runs for o in r.obstacles]))
    return windows


def _fit_across(window: Window, lines: list[np.ndarray], obstacles: list[np.ndarray]) -> Window:
    """The window widened across the road to hold the road's edges, the ego's paths and the obstacles."""
    points = lines + [d[:, :2] for d in obstacles] + [np.array([[e.x, e.y] for e in window.events])]
    uv = np.vstack([window.offsets(p) for p in points if len(p)])
    inside = uv[(np.abs(uv[:, 0]) <= window.length_m / 2 + 2.0) & (np.abs(uv[:, 1]) < 25.0)]
    low, high = (inside[:, 1].min() - 2.0, inside[:, 1].max() + 2.0) if len(inside) else (-6.0, 6.0)
    least = JUNCTION_ACROSS_M if any(e.kind in LIGHT_KINDS for e in window.events) else 12.0
    if high - low < least:
        middle = (low + high) / 2
        low, high = middle - least / 2, middle + least / 2
    return Window(window.centre, window.heading_rad, window.length_m, (float(low), float(high)), window.s_m,
                  window.events)


def snapshot_time(run: PlottedRun, window: Window) -> float | None:
    """When to show ``run``'s vehicles in ``window``: its own highest-ranked place there, else when its ego
    reaches the window's middle (None: it never does)."""
    own = [e for e in window.events if e.run == run.name]
    if own:
        return min(own, key=lambda e: (KIND_RANK.get(e.kind, 9), e.t)).t
    return run.time_at_s(window.s_m)
