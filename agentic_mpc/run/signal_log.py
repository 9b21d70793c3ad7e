"""The traffic lights the ego's route meets, over time: the rows of ``signals.csv``.

A row is written only when what the ego sees of a junction's light changes (small file): the first time the
junction is ahead with a light, each change of the light for the ego's movement (``green``, ``yellow``, ``red``,
``off``: :attr:`~agentic_mpc.world.observation.JunctionAhead.signal`), and ``unobserved`` when the junction is no
longer ahead (the ego has left it, or its route changed): from then on nothing is known of it. Junctions without
a light have no rows. Each row carries the stop line of the ego's movement: where along the route (``stop_s_m``)
and where in the world (``x_m``, ``y_m``, ``heading_rad`` of the ego's lane there), from the world's lanes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from agentic_mpc.world.lanes import RoadLanes
from agentic_mpc.world.observation import EgoObservation, Observation

UNOBSERVED = "unobserved"
"""The state of a junction that is no longer ahead of the ego."""
STATES = ("green", "yellow", "red", "off", UNOBSERVED)
HEADING_BEFORE_M = 1.0
"""The stop line's direction is the lane's this far before it."""


def stop_line_pose(lanes: RoadLanes, ego: EgoObservation, stop_s_m: float) -> tuple[float, float, float]:
    """(x, y, heading) of the point ``stop_s_m`` along the road on the ego's lane. A route is one lane whose
    path is the road's reference line (exact); on a carriageway of several lanes the ego's lane is followed
    from the ego on by the along-road distance to the line (lanes run parallel to the reference)."""
    paths = lanes.by_index or tuple(lanes.lanes.values())
    if len(paths) == 1:
        path, s_m = paths[0], stop_s_m
    else:
        index = ego.lane_index if ego.lane_index is not None and 0 <= ego.lane_index < len(paths) else 0
        path = paths[index]
        s_m = path.project(ego.x_m, ego.y_m) + stop_s_m - ego.road_s_m
    s_m = min(max(s_m, 0.0), path.length_m)
    # the heading of the lane that arrives (the line is where the curve through the junction starts)
    points, tangents = path.points_and_tangents_at([s_m, max(s_m - HEADING_BEFORE_M, 0.0)])
    return float(points[0][0]), float(points[0][1]), math.atan2(float(tangents[1][1]), float(tangents[1][0]))


@dataclass
class SignalLog:
    """Per step (:meth:`observe`): a row for each light that changed. ``lanes``: the world's lanes now (read
    only when a row is written: the route, and so the lanes, may change during a run)."""

    lanes: Callable[[], RoadLanes]
    rows: list[dict[str, Any]] = field(default_factory=list)
    _last: dict[str, dict[str, Any]] = field(default_factory=dict)
    """The last row of each junction still ahead."""

    def observe(self, observation: Observation) -> None:
        ahead = {j.junction_id: j for j in observation.junctions_ahead if j.signal is not None}
        for junction_id, junction in ahead.items():
            last = self._last.get(junction_id)
            if last is not None and last["state"] == junction.signal and last["stop_s_m"] == round(
                    junction.stop_s_m, 2):
                continue
            x, y, heading = stop_line_pose(self.lanes(), observation.ego, junction.stop_s_m)
            self._add(observation.time_s, junction_id, str(junction.signal), junction.stop_s_m, x, y, heading)
        for junction_id in [j for j in self._last if j not in ahead]:
            last = self._last.pop(junction_id)
            self.rows.append({**last, "time_s": round(observation.time_s, 3), "state": UNOBSERVED})

    def _add(self, time_s: float, junction_id: str, state: str, stop_s_m: float, x_m: float, y_m: float,
             heading_rad: float) -> None:
        row = {"time_s": round(time_s, 3), "junction_id": junction_id, "state": state,
               "stop_s_m": round(stop_s_m, 2), "x_m": round(x_m, 2), "y_m": round(y_m, 2),
               "heading_rad": round(heading_rad, 4)}
        self.rows.append(row)
        self._last[junction_id] = row
