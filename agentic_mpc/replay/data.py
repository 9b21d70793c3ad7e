"""A run directory read back into a compact, JSON-able scene for the replay page.

Reads ``trajectory.csv`` (the ego), ``traffic.csv`` (the other road users), ``obstacles.csv`` (J2's discs),
``events.csv`` (captions), ``scenario.json`` (the road, vehicle sizes) and, where present, ``plan.csv``
(``time_s, k, x_m, y_m[, ref_x_m, ref_y_m]``: the MPPI plan and J1's reference points at a stride).

Every CSV is read with the :mod:`csv` module, tolerating a cut last line: a run that crashed mid-write still
replays up to where its files end. ``traffic.csv`` has no vehicle sizes: they come from the ``vType``\\ s of
the run's route files, or :data:`DEFAULT_SIZES` by vehicle class.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import xml.etree.ElementTree as ElementTree
from pathlib import Path
from typing import Any

logger = logging.getLogger(__name__)

DEFAULT_SIZES: dict[str, tuple[float, float]] = {
    "passenger": (4.5, 1.8), "private": (4.5, 1.8), "taxi": (4.5, 1.8), "emergency": (6.5, 2.2),
    "truck": (12.0, 2.5), "trailer": (16.5, 2.55), "bus": (12.0, 2.5), "coach": (14.0, 2.6),
    "delivery": (6.5, 2.16), "motorcycle": (2.2, 0.9), "moped": (2.1, 0.8), "bicycle": (1.6, 0.65),
    "ego": (4.5, 1.8),
}
"""(length, width) in metres by SUMO vehicle class when the route files do not say (SUMO's own defaults)."""
TRAFFIC_HZ = 10.0
EGO_HZ = 20.0
CAPTION_CHARS = 400


class ReplayInputError(ValueError):
    """A directory that is not a run, or a run file that cannot be read."""


def read_rows(path: Path, required: tuple[str, ...] = (), notes: list[str] | None = None) -> list[dict[str, str]]:
    """The rows of a CSV file as dicts; a cut-off last line (a crashed run) is dropped with a note."""
    rows: list[dict[str, str]] = []
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.reader(handle)
            header = next(reader, None)
            if header is None:
                return rows
            missing = [c for c in required if c not in header]
            if missing:
                raise ReplayInputError(f"{path}: not a run file (missing columns {missing})")
            try:
                for values in reader:
                    if len(values) != len(header):
                        if notes is not None:
                            notes.append(f"{path.name}: a cut-off line after {len(rows)} rows was skipped")
                        continue
                    rows.append(dict(zip(header, values)))
            except csv.Error as error:
                if notes is not None:
                    notes.append(f"{path.name}: stopped reading after {len(rows)} rows ({error})")
    except (OSError, UnicodeDecodeError) as error:
        raise ReplayInputError(f"{path}: cannot be read ({error})") from error
    return rows


def _num(text: Any, default: float = math.nan) -> float:
    try:
        return float(text) if text not in (None, "") else default
    except ValueError:
        return default


def _r(value: float, digits: int = 2) -> float | None:
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


def _sumo_road(simulation: dict[str, Any]) -> tuple[list[Any], list[float], list[Any]]:
    """(lane centre lines left to right, their widths, [left edge, right edge]) of a SUMO run's road."""
    from agentic_mpc.sumo.network import RoadNetwork

    road_ref = simulation["road"]
    road = RoadNetwork(simulation["net_file"]).road(tuple(road_ref) if isinstance(road_ref, list) else road_ref)
    order = road.left_to_right
    return ([road.lane_paths[i] for i in order], [road.lane_widths_m[i] for i in order],
            [road.left_edge, road.right_edge])


def _plain_road(plain: dict[str, Any]) -> tuple[list[Any], list[float], list[Any]]:
    from agentic_mpc.world.plain import PlainWorld
    from agentic_mpc.world.plain_config import PlainConfig

    world = PlainWorld(PlainConfig.model_validate(plain))
    try:
        paths = list(world.lanes().lanes.values())
        width = float(world.config.road.lane_width_m)
    finally:
        world.close()
    paths.sort(key=lambda p: -float(p.coordinates[0][1]))  # the plain road runs along +x: left is +y
    return paths, [width] * len(paths), [paths[0].parallel(width / 2), paths[-1].parallel(-width / 2)]


def road_geometry(scenario: dict[str, Any], box: tuple[float, float, float, float]) -> dict[str, Any]:
    """Lane centre lines, lane boundaries and road edges near the run (inside ``box``) as polylines."""
    if scenario.get("simulation"):
        lanes, widths, edges = _sumo_road(scenario["simulation"])
    elif scenario.get("plain_world"):
        lanes, widths, edges = _plain_road(scenario["plain_world"])
    else:
        return {}
    boundaries = [lane.parallel(-w / 2).coordinates for lane, w in zip(lanes[:-1], widths[:-1])]

    def parts(lines: list[Any]) -> list[list[list[float]]]:
        return [part for line in lines for part in _clip(line, box)]

    return {"lanes": parts([lane.coordinates for lane in lanes]), "boundaries": parts(boundaries),
            "edges": [_clip(edges[0].coordinates, box), _clip(edges[1].coordinates, box)],
            "lane_width_m": round(sum(widths) / len(widths), 2)}


def vehicle_sizes(scenario: dict[str, Any], notes: list[str]) -> dict[str, tuple[float, float]]:
    """(length, width) per vType id from the run's route files; the plain world's vehicles by id."""
    sizes: dict[str, tuple[float, float]] = {}
    for route_file in (scenario.get("simulation") or {}).get("route_files", []):
        try:
            for vtype in ElementTree.parse(route_file).getroot().iter("vType"):
                cls = vtype.get("vClass", "passenger")
                length, width = DEFAULT_SIZES.get(cls, DEFAULT_SIZES["passenger"])
                sizes[vtype.get("id", "")] = (float(vtype.get("length", length)), float(vtype.get("width", width)))
        except (OSError, ElementTree.ParseError, ValueError) as error:
            notes.append(f"vehicle sizes from {route_file} unavailable ({error}); class defaults used")
    for vehicle in (scenario.get("plain_world") or {}).get("vehicles", []):
        diameter = 2.0 * float(vehicle.get("radius_m", 2.0))
        sizes["@" + vehicle["id"]] = (diameter, min(diameter, 1.9))
    return sizes


def size_of(sizes: dict[str, tuple[float, float]], vehicle_id: str, type_id: str, vclass: str) -> tuple[float, float]:
    for key in ("@" + vehicle_id, type_id, type_id.split("@")[0]):
        if key in sizes:
            return sizes[key]
    return DEFAULT_SIZES.get(vclass, DEFAULT_SIZES["passenger"])


def _ego(rows: list[dict[str, str]]) -> dict[str, Any]:
    t = [_num(r.get("time_s")) for r in rows]
    v = [_num(r.get("v_mps")) for r in rows]
    n = len(rows)
    accel = []
    half = max(1, round(0.1 / ((t[-1] - t[0]) / (n - 1)))) if n > 1 and t[-1] > t[0] else 1
    for i in range(n):  # central differences over +-0.1 s: step-to-step noise stays out of the plot
        a, b = max(0, i - half), min(n - 1, i + half)
        accel.append((v[b] - v[a]) / (t[b] - t[a]) if t[b] > t[a] else 0.0)
    dt = (t[-1] - t[0]) / max(n - 1, 1) if n > 1 else 0.04
    stride = max(1, round(1.0 / (EGO_HZ * dt))) if dt > 0 else 1
    keep = list(range(0, n, stride)) + ([n - 1] if (n - 1) % stride else [])
    track = [[_r(t[i], 3), _r(_num(rows[i].get("x_m"))), _r(_num(rows[i].get("y_m"))),
              _r(_num(rows[i].get("phi_rad")), 3), _r(v[i]), _r(accel[i])] for i in keep]
    specs: list[list[Any]] = []
    for r in rows:
        summary = r.get("spec_summary", "")
        if not specs or specs[-1][2] != summary:
            specs.append([_r(_num(r.get("time_s")), 3), r.get("spec_version", ""), summary])
    return {"columns": ["t", "x", "y", "heading", "v", "a"], "track": track, "specs": specs}


def _traffic(rows: list[dict[str, str]], sizes: dict[str, tuple[float, float]]) -> dict[str, Any]:
    vehicles: dict[str, dict[str, Any]] = {}
    index: dict[str, int] = {}
    frames: list[list[Any]] = []
    last_t = -math.inf
    for r in rows:
        t = _num(r.get("time_s"))
        if not math.isfinite(t):
            continue
        if not frames or t != frames[-1][0]:
            if t - last_t < 1.0 / TRAFFIC_HZ - 1e-6:
                continue
            frames.append([_r(t, 3), []])
            last_t = t
        elif t != last_t:
            continue
        vid = r.get("id", "")
        if vid not in index:
            emergency = r.get("emergency", "").lower() == "true" or r.get("vclass") == "emergency"
            length, width = size_of(sizes, vid, r.get("type_id", ""), r.get("vclass", ""))
            index[vid] = len(vehicles)
            vehicles[vid] = {"id": vid, "type": r.get("type_id", ""), "cls": r.get("vclass", ""),
                             "L": round(length, 2), "W": round(width, 2), "em": emergency}
        frames[-1][1].append([index[vid], _r(_num(r.get("x_m"))), _r(_num(r.get("y_m"))),
                              _r(_num(r.get("heading_rad")), 3), _r(_num(r.get("speed_mps")), 1)])
    return {"vehicles": list(vehicles.values()), "frames": frames}


def obstacle_items(rows: list[dict[str, str]], sizes: dict[str, tuple[float, float]]) -> list[dict[str, Any]]:
    """J2's discs per obstacle, and a stopped car's footprint where its discs line up (SUMO obstacles)."""
    groups: dict[str, list[tuple[float, float, float]]] = {}
    for r in rows:
        groups.setdefault(r.get("id", ""), []).append((_num(r.get("x_m")), _num(r.get("y_m")), _num(r.get("radius_m"))))
    out = []
    for obstacle_id, discs in groups.items():
        item: dict[str, Any] = {"id": obstacle_id, "discs": [[_r(x), _r(y), _r(rad)] for x, y, rad in discs]}
        if len(discs) > 1:
            (x0, y0, _), (x1, y1, _) = max(((a, b) for a in discs for b in discs),
                                           key=lambda ab: math.dist(ab[0][:2], ab[1][:2]))
            length, width = sizes.get("obstacle", DEFAULT_SIZES["passenger"])
            item["car"] = [_r((x0 + x1) / 2), _r((y0 + y1) / 2), _r(math.atan2(y1 - y0, x1 - x0), 3),
                           round(length, 2), round(width, 2)]
        out.append(item)
    return out


def _short(text: str) -> str:
    text = " ".join(text.split())
    return text if len(text) <= CAPTION_CHARS else text[: CAPTION_CHARS - 1] + "…"


def captions_of(rows: list[dict[str, Any]], own_calls: bool | None = None) -> list[dict[str, Any]]:
    """Passenger and observation messages, the agent's replies and its tool calls, at their sim times.
    ``own_calls``: whether an embedded agent made calls (then the MCP server's receipts of them are not shown
    twice); None: decided from ``rows``."""
    if own_calls is None:
        own_calls = any(r.get("event") == "tool_call" for r in rows)
    captions = []
    for r in rows:
        t = _num(r.get("sim_time_s"))
        if not math.isfinite(t):
            continue
        event, role = r.get("event"), r.get("role")
        if event == "message" and role == "user":
            kind = "observation" if r.get("source") == "observation" else "passenger"
            captions.append({"t": _r(t, 3), "kind": kind, "text": _short(r.get("content", ""))})
        elif event == "message" and role == "assistant" and r.get("content", "").strip():
            captions.append({"t": _r(t, 3), "kind": "agent", "text": _short(r["content"])})
        elif event == "tool_call" or (event == "tool_call_received" and not own_calls):
            try:
                args = json.loads(r.get("arguments") or "{}")
                shown = ", ".join(f"{k}={v}" for k, v in args.items()) if isinstance(args, dict) else str(args)
            except json.JSONDecodeError:
                shown = r.get("arguments", "")
            who = "" if event == "tool_call" else f" [{r.get('client') or 'MCP host'}]"
            captions.append({"t": _r(t, 3), "kind": "tool", "text": _short(f"{r.get('tool')}({shown}){who}")})
    return captions


def _plan(rows: list[dict[str, str]]) -> list[list[Any]]:
    """[t, [[x, y], ...], [[ref_x, ref_y], ...]] per recorded step, at most :data:`TRAFFIC_HZ`."""
    steps: dict[float, tuple[list[list[float | None]], list[list[float | None]]]] = {}
    for r in sorted(rows, key=lambda r: (_num(r.get("time_s")), _num(r.get("k")))):
        t = _num(r.get("time_s"))
        if not math.isfinite(t):
            continue
        plan, ref = steps.setdefault(t, ([], []))
        plan.append([_r(_num(r.get("x_m"))), _r(_num(r.get("y_m")))])
        if "ref_x_m" in r and math.isfinite(_num(r.get("ref_x_m"))):
            ref.append([_r(_num(r.get("ref_x_m"))), _r(_num(r.get("ref_y_m")))])
    out: list[list[Any]] = []
    for t in sorted(steps):
        if not out or t - out[-1][0] >= 1.0 / TRAFFIC_HZ - 1e-6:
            out.append([_r(t, 3), *steps[t]])
    return out


def load_run(directory: Path) -> dict[str, Any]:
    """The scene of the run in ``directory``; raises :class:`ReplayInputError` for a non-run."""
    directory = Path(directory)
    trajectory_path = directory / "trajectory.csv"
    if not directory.is_dir():
        raise ReplayInputError(f"{directory}: no such directory")
    if not trajectory_path.is_file():
        raise ReplayInputError(f"{directory} is not a run directory: {trajectory_path} is missing")
    notes: list[str] = []
    trajectory = read_rows(trajectory_path, ("time_s", "x_m", "y_m", "phi_rad", "v_mps"), notes)
    trajectory = [r for r in trajectory if math.isfinite(_num(r["time_s"])) and math.isfinite(_num(r["x_m"]))]
    if not trajectory:
        raise ReplayInputError(f"{trajectory_path}: no control steps recorded (empty or cut-off file)")
    scenario: dict[str, Any] = {}
    scenario_path = directory / "scenario.json"
    if scenario_path.is_file():
        try:
            scenario = json.loads(scenario_path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as error:
            notes.append(f"scenario.json unreadable ({error}): no road drawn")
    else:
        notes.append("scenario.json missing: no road drawn")
    sizes = vehicle_sizes(scenario, notes)

    def optional(name: str, required: tuple[str, ...]) -> list[dict[str, str]]:
        path = directory / name
        return read_rows(path, required, notes) if path.is_file() else []

    ego = _ego(trajectory)
    xs = [p[1] for p in ego["track"] if p[1] is not None]
    ys = [p[2] for p in ego["track"] if p[2] is not None]
    margin = 150.0
    box = (min(xs) - margin, min(ys) - margin, max(xs) + margin, max(ys) + margin)
    road: dict[str, Any] = {}
    if scenario:
        try:
            road = road_geometry(scenario, box)
        except Exception as error:  # the scene without a road beats no scene
            logger.warning("replay of %s: no road (%s)", directory, error)
            notes.append(f"road not drawn: {type(error).__name__}: {error}")
    summary = optional("summary.csv", ())
    ego_type = (scenario.get("simulation") or {}).get("ego_type_id", "ego")
    ego_size = sizes.get(ego_type) or ((4.5, 1.8) if scenario.get("plain_world") else DEFAULT_SIZES["ego"])
    return {
        "title": " / ".join(str(scenario.get(k, "?")) for k in ("name", "variant", "seed")) if scenario else directory.name,
        "description": scenario.get("description", ""),
        "summary": summary[0] if summary else {},
        "road": road,
        "ego": {**ego, "L": ego_size[0], "W": ego_size[1]},
        "traffic": _traffic(optional("traffic.csv", ("time_s", "id", "x_m", "y_m")), sizes),
        "obstacles": obstacle_items(optional("obstacles.csv", ("id", "x_m", "y_m", "radius_m")), sizes),
        "captions": captions_of(optional("events.csv", ("event", "sim_time_s"))),
        "plan": _plan(optional("plan.csv", ("time_s", "k", "x_m", "y_m"))),
        "notes": notes,
    }
