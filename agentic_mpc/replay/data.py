"""A run directory read back (through :mod:`agentic_mpc.run.reader`) into a compact, JSON-able scene for the
replay page.

The scene holds the ego (``trajectory.csv``), the other road users (``traffic.csv``), J2's discs
(``obstacles.csv``), captions (``events.csv``), the road (rebuilt from ``scenario.json`` by
:mod:`agentic_mpc.plots.road`; on a SUMO network also the streets and junctions around the ego's path, by
:mod:`agentic_mpc.plots.network`), the traffic lights the route met (``signals.csv``) and, where present,
``plan.csv`` (``time_s, k, x_m, y_m[, ref_x_m, ref_y_m]``: the MPPI plan and J1's reference points at a stride).
A run that crashed mid-write replays up to where its files end; the live view (:mod:`~agentic_mpc.replay.live`)
builds the same scene from a running loop.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from agentic_mpc.run.files import EVENTS, PLAN, SIGNALS, SUMMARY, TRAFFIC, TRAJECTORY
from agentic_mpc.run.reader import (
    Obstacle,
    RunDirectoryError,
    ego_size,
    is_emergency,
    number,
    read_run,
    size_of,
)

logger = logging.getLogger(__name__)

TRAFFIC_HZ = 10.0
EGO_HZ = 20.0
CAPTION_CHARS = 400
TRACK_COLUMNS = ("t", "x", "y", "heading", "v", "a")
"""The columns of the scene's ego track."""
ROAD_MARGIN_M = 150.0
"""How far around the ego's path the road and the network are drawn."""

ReplayInputError = RunDirectoryError
"""A directory that is not a run, or a run file that cannot be read (the reader's error)."""


def rounded(value: float, digits: int = 2) -> float | None:
    """A number for the scene's JSON: rounded, None for NaN and infinities."""
    return None if not math.isfinite(value) else round(value, digits)


def _simplify(coordinates: Any, tolerance_m: float = 0.05) -> list[list[float]]:
    import shapely

    line = shapely.simplify(shapely.LineString(coordinates), tolerance_m)
    return [[round(x, 2), round(y, 2)] for x, y in line.coords]


def _clip(coordinates: Any, box: tuple[float, float, float, float]) -> list[list[list[float]]]:
    """The parts of a polyline inside ``box`` (xmin, ymin, xmax, ymax), simplified."""
    import shapely

    clipped = shapely.clip_by_rect(shapely.LineString(coordinates), *box)
    parts = getattr(clipped, "geoms", [clipped])
    return [_simplify(list(p.coords)) for p in parts if not p.is_empty and len(p.coords) > 1]


def road_geometry(scenario: Mapping[str, Any], box: tuple[float, float, float, float],
                  region: Any = None) -> dict[str, Any]:
    """Lane centre lines, lane boundaries and road edges near the run (inside ``box``) as polylines; on a SUMO
    network also ``network`` (:meth:`~agentic_mpc.plots.network.NetworkDrawing.to_json`: the other streets'
    lanes, their dividers and the junctions inside ``region``, a shapely geometry; default ``box``), where
    there is any beside the road."""
    from agentic_mpc.plots.road import run_road

    road = run_road(scenario)
    if road is None:
        return {}
    lanes, widths = road.left_to_right, road.widths_m
    boundaries = [lane.parallel(-w / 2).coordinates for lane, w in zip(lanes[:-1], widths[:-1])]

    def parts(lines: list[Any]) -> list[list[list[float]]]:
        return [part for line in lines for part in _clip(line, box)]

    geometry = {"lanes": parts([lane.coordinates for lane in lanes]), "boundaries": parts(boundaries),
                "edges": [_clip(edge.coordinates, box) for edge in road.edges],
                "lane_width_m": round(sum(widths) / len(widths), 2)}
    if scenario.get("simulation"):
        import shapely

        from agentic_mpc.plots.network import sumo_network_near

        network = sumo_network_near(scenario["simulation"], region if region is not None else shapely.box(*box))
        if network:
            geometry["network"] = network.to_json()
    return geometry


def signal_change(row: Mapping[str, Any]) -> list[Any]:
    """One ``signals.csv`` row as the page keeps it: [t, state, x, y, heading]."""
    return [rounded(number(row.get("time_s")), 3), str(row.get("state", "")), rounded(number(row.get("x_m"))),
            rounded(number(row.get("y_m"))), rounded(number(row.get("heading_rad")), 3)]


def signal_items(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``signals.csv`` per junction: its id and its changes [t, state, x, y, heading] in time order."""
    junctions: dict[str, dict[str, Any]] = {}
    for r in rows:
        if not math.isfinite(number(r.get("time_s"))):
            continue
        junction_id = str(r.get("junction_id", ""))
        junctions.setdefault(junction_id, {"id": junction_id, "changes": []})["changes"].append(signal_change(r))
    for junction in junctions.values():
        junction["changes"].sort(key=lambda change: change[0])
    return list(junctions.values())


def _ego(rows: list[dict[str, str]]) -> dict[str, Any]:
    t = [number(r.get("time_s")) for r in rows]
    v = [number(r.get("v_mps")) for r in rows]
    n = len(rows)
    accel = []
    half = max(1, round(0.1 / ((t[-1] - t[0]) / (n - 1)))) if n > 1 and t[-1] > t[0] else 1
    for i in range(n):  # central differences over +-0.1 s: step-to-step noise stays out of the plot
        a, b = max(0, i - half), min(n - 1, i + half)
        accel.append((v[b] - v[a]) / (t[b] - t[a]) if t[b] > t[a] else 0.0)
    dt = (t[-1] - t[0]) / max(n - 1, 1) if n > 1 else 0.04
    stride = max(1, round(1.0 / (EGO_HZ * dt))) if dt > 0 else 1
    keep = list(range(0, n, stride)) + ([n - 1] if (n - 1) % stride else [])
    track = [[rounded(t[i], 3), rounded(number(rows[i].get("x_m"))), rounded(number(rows[i].get("y_m"))),
              rounded(number(rows[i].get("phi_rad")), 3), rounded(v[i]), rounded(accel[i])] for i in keep]
    specs: list[list[Any]] = []
    for r in rows:
        add_spec(specs, number(r.get("time_s")), r.get("spec_version", ""), r.get("spec_summary", ""))
    return {"columns": list(TRACK_COLUMNS), "track": track, "specs": specs}


def add_spec(specs: list[list[Any]], t: float, version: Any, summary: str) -> None:
    """The specification attached at ``t``, if it is not the one attached before."""
    if not specs or specs[-1][2] != summary:
        specs.append([rounded(t, 3), version, summary])


class TrafficFrames:
    """The other road users' frames (at most :data:`TRAFFIC_HZ`) and who they are, built row by row."""

    def __init__(self, sizes: Mapping[str, tuple[float, float]]) -> None:
        self.sizes = sizes
        self.vehicles: dict[str, dict[str, Any]] = {}
        self.frames: list[list[Any]] = []
        self._index: dict[str, int] = {}
        self._last_t = -math.inf

    def add(self, row: Mapping[str, Any]) -> None:
        """One ``traffic.csv`` row (strings or numbers); rows of a time too soon after the last frame are left out."""
        t = number(row.get("time_s"))
        if not math.isfinite(t):
            return
        if t != self._last_t:
            if t - self._last_t < 1.0 / TRAFFIC_HZ - 1e-6:
                return
            self.frames.append([rounded(t, 3), []])
            self._last_t = t
        vid = str(row.get("id", ""))
        if vid not in self._index:
            type_id, vclass = str(row.get("type_id", "")), str(row.get("vclass", ""))
            length, width = size_of(self.sizes, vid, type_id, vclass)
            self._index[vid] = len(self.vehicles)
            self.vehicles[vid] = {"id": vid, "type": row.get("type_id", ""), "cls": row.get("vclass", ""),
                                  "L": round(length, 2), "W": round(width, 2),
                                  "em": is_emergency(row.get("emergency", ""), row.get("vclass"))}
        self.frames[-1][1].append([self._index[vid], rounded(number(row.get("x_m"))), rounded(number(row.get("y_m"))),
                                   rounded(number(row.get("heading_rad")), 3),
                                   rounded(number(row.get("speed_mps")), 1)])


def obstacle_items(obstacles: Iterable[Obstacle], sizes: Mapping[str, tuple[float, float]]) -> list[dict[str, Any]]:
    """J2's discs per obstacle, and a stopped car's footprint where its discs line up (SUMO obstacles)."""
    out = []
    for obstacle in obstacles:
        item: dict[str, Any] = {"id": obstacle.id,
                                "discs": [[rounded(x), rounded(y), rounded(r)] for x, y, r in obstacle.discs]}
        car = obstacle.car(sizes)
        if car is not None:
            x, y, heading, length, width = car
            item["car"] = [rounded(x), rounded(y), rounded(heading, 3), round(length, 2), round(width, 2)]
        out.append(item)
    return out


def _short(text: str) -> str:
    text = " ".join(text.split())
    return text if len(text) <= CAPTION_CHARS else text[: CAPTION_CHARS - 1] + "…"


def _tactic_caption(event: str, row: dict[str, Any]) -> str:
    """What a tactic changed, in words: 'tactic merge_ahead_of_queue: J1 on lane 2 (not 1) past stopped_straight'."""
    try:
        tactic = json.loads(row.get("result") or "{}")
    except (TypeError, ValueError):
        tactic = {}
    if event == "tactic_ended":
        return f"tactic {row.get('content', '')} ended"
    return (f"tactic {row.get('content', '')}: J1 on lane {tactic.get('followed_lane')} "
            f"(not {tactic.get('tracked_lane')}) past {tactic.get('obstacle_id')}")


def captions_of(rows: list[dict[str, Any]], own_calls: bool | None = None) -> list[dict[str, Any]]:
    """Passenger and observation messages, the agent's replies, its tool calls and the ego's stuck intervals
    (``stuck`` events), at their sim times.
    ``own_calls``: whether an embedded agent made calls (then the MCP server's receipts of them are not shown
    twice); None: decided from ``rows``."""
    if own_calls is None:
        own_calls = any(r.get("event") == "tool_call" for r in rows)
    captions = []
    for r in rows:
        t = number(r.get("sim_time_s"))
        if not math.isfinite(t):
            continue
        event, role = r.get("event"), r.get("role")
        if event == "message" and role == "user":
            kind = "observation" if r.get("source") == "observation" else "passenger"
            captions.append({"t": rounded(t, 3), "kind": kind, "text": _short(r.get("content", ""))})
        elif event == "stuck":
            captions.append({"t": rounded(t, 3), "kind": "stuck", "text": _short(r.get("content", ""))})
        elif event in ("tactic_started", "tactic_ended"):
            captions.append({"t": rounded(t, 3), "kind": "tactic", "text": _short(_tactic_caption(event, r))})
        elif event == "message" and role == "assistant" and r.get("content", "").strip():
            captions.append({"t": rounded(t, 3), "kind": "agent", "text": _short(r["content"])})
        elif event == "tool_call" or (event == "tool_call_received" and not own_calls):
            try:
                args = json.loads(r.get("arguments") or "{}")
                shown = ", ".join(f"{k}={v}" for k, v in args.items()) if isinstance(args, dict) else str(args)
            except json.JSONDecodeError:
                shown = r.get("arguments", "")
            who = "" if event == "tool_call" else f" [{r.get('client') or 'MCP host'}]"
            captions.append({"t": rounded(t, 3), "kind": "tool", "text": _short(f"{r.get('tool')}({shown}){who}")})
    return captions


def _plan(rows: list[dict[str, str]]) -> list[list[Any]]:
    """[t, [[x, y], ...], [[ref_x, ref_y], ...]] per recorded step, at most :data:`TRAFFIC_HZ`."""
    steps: dict[float, tuple[list[list[float | None]], list[list[float | None]]]] = {}
    for r in sorted(rows, key=lambda r: (number(r.get("time_s")), number(r.get("k")))):
        t = number(r.get("time_s"))
        if not math.isfinite(t):
            continue
        plan, ref = steps.setdefault(t, ([], []))
        plan.append([rounded(number(r.get("x_m"))), rounded(number(r.get("y_m")))])
        if "ref_x_m" in r and math.isfinite(number(r.get("ref_x_m"))):
            ref.append([rounded(number(r.get("ref_x_m"))), rounded(number(r.get("ref_y_m")))])
    out: list[list[Any]] = []
    for t in sorted(steps):
        if not out or t - out[-1][0] >= 1.0 / TRAFFIC_HZ - 1e-6:
            out.append([rounded(t, 3), *steps[t]])
    return out


def scene(scenario: Mapping[str, Any], sizes: Mapping[str, tuple[float, float]], title: str,
          **parts: Any) -> dict[str, Any]:
    """The scene of the replay page: the run's identity, then ``parts`` (the ego gets its size)."""
    length, width = ego_size(scenario, sizes)
    parts["ego"] = {**parts["ego"], "L": length, "W": width}
    return {"title": title, "description": scenario.get("description", ""), **parts}


def load_run(directory: Path) -> dict[str, Any]:
    """The scene of the run in ``directory``; raises :class:`ReplayInputError` for a non-run."""
    run = read_run(directory)
    trajectory = [r for r in run.rows(TRAJECTORY)
                  if math.isfinite(number(r["time_s"])) and math.isfinite(number(r["x_m"]))]
    if not trajectory:
        raise ReplayInputError(f"{run.file(TRAJECTORY)}: no control steps recorded (empty or cut-off file)")
    scenario, sizes = run.scenario, run.sizes
    ego = _ego(trajectory)
    xs = [p[1] for p in ego["track"] if p[1] is not None]
    ys = [p[2] for p in ego["track"] if p[2] is not None]
    margin = ROAD_MARGIN_M
    box = (min(xs) - margin, min(ys) - margin, max(xs) + margin, max(ys) + margin)
    road: dict[str, Any] = {}
    if scenario:
        try:
            from agentic_mpc.plots.network import corridor

            path = [[p[1], p[2]] for p in ego["track"] if p[1] is not None and p[2] is not None]
            road = road_geometry(scenario, box, corridor([path], margin))
        except Exception as error:  # the scene without a road beats no scene
            logger.warning("replay of %s: no road (%s)", run.path, error)
            run.notes.append(f"road not drawn: {type(error).__name__}: {error}")
    summary = run.rows(SUMMARY)
    traffic = TrafficFrames(sizes)
    for row in run.rows(TRAFFIC):
        traffic.add(row)
    return scene(
        scenario, sizes, run.title, summary=summary[0] if summary else {}, road=road, ego=ego,
        traffic={"vehicles": list(traffic.vehicles.values()), "frames": traffic.frames},
        obstacles=obstacle_items(run.obstacles, sizes), captions=captions_of(run.rows(EVENTS)),
        plan=_plan(run.rows(PLAN)), signals=signal_items(run.rows(SIGNALS)), notes=run.notes,
    )
