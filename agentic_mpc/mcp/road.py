"""The ``sumo://road`` resource: the ego's road as a driver (or a language model) needs to know it.

Built from the world's :class:`~agentic_mpc.world.lanes.RoadLanes` (the lanes the tools drive on, by the
names the tools use, the speed limit, the handedness) and the initial specification (which lane and speed
"resume" restores). Plain JSON, the same for the SUMO world and the plain-Python one:

- ``traffic``: ``"left-hand"`` or ``"right-hand"``; ``keep_to``: the side traffic keeps to;
- ``lanes``: from the road edge outwards, each ``{"name", "index", "role", "tool"}``; ``index`` is the lane's
  index as SUMO counts them (0 is the edge lane: the rightmost in right-hand traffic, the leftmost in
  left-hand traffic);
- ``edge_lane``: where the car pulls over to yield; ``emergency_lane``: the hard shoulder, where the road has
  one (``pull_over``); ``speed_limit_mps`` (and ``_kmh``); a road with more lanes than the three roles lists
  every lane (``lane<i>``, driven with ``keep_lane``);
- ``yield`` / ``resume``: one plain-English sentence each, with the call (``yield_call`` / ``resume_call``);
- ``summary``: the road in one line.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from agentic_mpc.world.lanes import RoadLanes

LaneIndex = Callable[[Any], int | None]
"""The world's ``lane_index_of``: a lane path's index on the ego's road (None if unknown)."""

_LEFT_TO_RIGHT = ("left", "center", "right")


def _call_text(tool: str, arguments: dict[str, Any]) -> str:
    return f"{tool}({', '.join(f'{k}={v:g}' if isinstance(v, float) else f'{k}={v}' for k, v in arguments.items())})"


def describe_road(
    road: RoadLanes, initial_lane: str | None = None, initial_speed_mps: float | None = None,
    lane_index: LaneIndex | None = None,
) -> dict[str, Any]:
    """The ``sumo://road`` JSON of ``road``; ``initial_lane`` and ``initial_speed_mps`` (the initial path
    tracking) make ``resume`` concrete; ``lane_index`` gives the world's lane indices (else counted from the
    edge lane, which is SUMO's numbering for roads of up to three lanes)."""
    keep_to, far_side = ("left", "right") if road.lefthand else ("right", "left")
    traffic = f"{keep_to}-hand"
    names = [name for name in _LEFT_TO_RIGHT if name in road.lanes]
    if road.by_index and len(road.by_index) > len(names):  # more lanes than roles: every lane, by its name
        names = [road.label(index) for index in road.left_to_right]
    shoulder = road.label(road.shoulder_index) if road.by_index and road.shoulder_index is not None else None
    from_edge = names if road.lefthand else names[::-1]
    edge = from_edge[0] if from_edge else None
    lanes = []
    for position, name in enumerate(from_edge):
        path = road.lanes.get(name) or road.by_index[int(name.removeprefix("lane"))]
        index = lane_index(path) if lane_index is not None else None
        if name == shoulder:
            role = "emergency lane (hard shoulder): for stopping only; pull_over() drives onto it and stops"
        elif name == edge:
            role = f"edge lane, next to the {keep_to} edge of the road: traffic keeps to it; pull over here to yield"
        elif position == len(from_edge) - 1:
            role = f"overtaking lane, the farthest from the road edge (on the {far_side})"
        else:
            role = "middle lane"
        lanes.append({"name": name, "index": index if isinstance(index, int) else position, "role": role,
                      "tool": f"run_{name}_lane" if name in road.lanes else f"keep_lane(index={index})"})
    limit = float(road.speed_limit_mps)
    out: dict[str, Any] = {
        "traffic": traffic, "lefthand": bool(road.lefthand), "keep_to": keep_to, "lanes": lanes,
        "edge_lane": edge, "speed_limit_mps": limit, "speed_limit_kmh": round(limit * 3.6, 1),
    }
    if shoulder is not None:
        out["emergency_lane"] = shoulder
    if edge is not None:
        yield_call = {"tool": f"run_{edge}_lane", "arguments": {"v_ref": 0.0}}
        out["yield_call"] = yield_call
        out["yield"] = (
            "To yield to an emergency vehicle (an ambulance, a fire engine, a police car with sirens) coming up "
            f"behind, pull over to the {edge} lane, the edge lane in this {traffic} traffic, and stop there: call "
            f"{_call_text(yield_call['tool'], yield_call['arguments'])}, not a steering preference."
        )
    resume = ("To resume once the emergency vehicle has passed (it is gone, it has left), restore the initial "
              "lane and speed of the initial specification (mpc://specification/initial)")
    if initial_lane in road.lanes and initial_speed_mps is not None:
        resume_call = {"tool": f"run_{initial_lane}_lane", "arguments": {"v_ref": float(initial_speed_mps)}}
        out["resume_call"] = resume_call
        resume += f": call {_call_text(resume_call['tool'], resume_call['arguments'])}"
    out["resume"] = resume + "."
    listed = ", ".join(f"{lane['name']} (index {lane['index']}{', edge lane' if lane['name'] == edge else ''})"
                       for lane in lanes)
    out["summary"] = (f"{traffic.capitalize()} traffic (vehicles keep to the {keep_to}); lanes {listed}; "
                      f"speed limit {limit:g} m/s ({limit * 3.6:g} km/h).")
    return out
