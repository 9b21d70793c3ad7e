"""The lanes of the network that are not the ego's road, as lines to predict their vehicles along.

On a route through junctions most traffic is on lanes the ego's road does not contain: oncoming lanes, the
crossing streets, the junctions' internal lanes. Predicted at constant heading, a car on the oncoming lane of a
slightly curved street drifts into the ego's lane within the horizon and holds the ego (measured on SUMO's
``cross``); along its lane it does not. Each lane is continued by its successors while it has exactly one (an
internal lane always has: it leads to its outgoing lane); where it has several, by the connection to the street
the vehicle's route takes next (a car about to make a U-turn is predicted round it, not straight past the ego),
else straight on, so a prediction never runs off it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agentic_mpc.geometry import LanePath
from agentic_mpc.polylines.kernels import locate
from agentic_mpc.polylines.polyline import Polyline
from agentic_mpc.world.observation import VehicleObservation

CONTINUE_M = 80.0
"""How far beyond a lane's end its line goes on (successors, then straight)."""
BEHIND_M = 15.0
"""How far before a lane's start its line reaches back (its one predecessor's end): SUMO puts a vehicle on the lane
its front is on, and a 12 m truck turning off the ego's lane has its centre up to 6 m before that lane's start;
projected onto the lane's start, its cover sat ahead of its body, and the ego drove into its rear (tuning seed
318 of the OpenStreetMap route)."""


class LaneTables:
    """A :class:`Polyline` per SUMO lane id, built on first use from a sumolib network."""

    def __init__(self, net: Any) -> None:
        self.net = net
        self._tables: dict[tuple[str, str], tuple[Polyline, LanePath] | None] = {}

    def table(self, lane_id: str, next_edge_id: str = "") -> tuple[Polyline, LanePath] | None:
        """The lane's line continued beyond its end, through the junction towards ``next_edge_id`` where the lane
        has several ways on (None: no such lane)."""
        key = (lane_id, next_edge_id)
        if key not in self._tables:
            self._tables[key] = self._build(lane_id, next_edge_id)
        return self._tables[key]

    def place(self, vehicle: VehicleObservation) -> tuple[Polyline, tuple[float, ...]] | None:
        """The line ``vehicle``'s front drives along (its lane, on the way its route goes) and where it is on it:
        (speed, the front's arc length, its lateral offset, length, x, y, heading, acceleration), the row of
        :func:`~agentic_mpc.polylines.kernels.body_disc_centres` without the disc's offset. None off every lane."""
        found = self.table(vehicle.lane_id, vehicle.next_edge_id) if vehicle.lane_id else None
        if found is None:
            return None
        line, path = found
        half = 0.5 * vehicle.length_m
        front_x = vehicle.x_m + half * math.cos(vehicle.heading_rad)
        front_y = vehicle.y_m + half * math.sin(vehicle.heading_rad)
        front_s = path.project(front_x, front_y)
        lateral = locate(line, front_x, front_y, front_s)[1]
        return line, (vehicle.speed_mps, front_s, lateral, vehicle.length_m, vehicle.x_m, vehicle.y_m,
                      vehicle.heading_rad, vehicle.accel_mps2)

    def _build(self, lane_id: str, next_edge_id: str) -> tuple[Polyline, LanePath] | None:
        try:
            lane = self.net.getLane(lane_id)
        except KeyError:
            return None
        points = _tail(lane, BEHIND_M) + [(float(x), float(y)) for x, y in lane.getShape()]
        beyond = 0.0
        while beyond < CONTINUE_M:
            onward = lane.getOutgoing()
            if len(onward) > 1:  # the one to the street its route takes (the first, if several lanes go there)
                onward = [c for c in onward if c.getTo().getID() == next_edge_id][:1]
                next_edge_id = ""  # beyond the next street: its route is not read
            if len(onward) != 1:
                break
            via = onward[0].getViaLaneID()
            lane = self.net.getLane(via) if via else onward[0].getToLane()
            shape = [(float(x), float(y)) for x, y in lane.getShape()]
            beyond += sum(math.dist(a, b) for a, b in zip(shape, shape[1:]))
            points.extend(shape if math.dist(points[-1], shape[0]) > 1e-6 else shape[1:])
        (x0, y0), (x1, y1) = points[-2], points[-1]
        length = math.hypot(x1 - x0, y1 - y0) or 1.0
        points.append((x1 + (x1 - x0) / length * CONTINUE_M, y1 + (y1 - y0) / length * CONTINUE_M))
        path = LanePath(np.array(points), name=lane_id)
        return Polyline(path), path


def _tail(lane: Any, length_m: float) -> list[tuple[float, float]]:
    """The last ``length_m`` of the shape of the lane's one predecessor, without its end point (the lane's
    start); none if it has none or several."""
    before = lane.getIncoming()
    if len(before) != 1:
        return []
    shape = [(float(x), float(y)) for x, y in before[0].getShape()]
    kept, left = [], length_m
    for a, b in zip(reversed(shape[:-1]), reversed(shape[1:])):
        step = math.dist(a, b)
        if step >= left:
            t = left / step if step > 0 else 0.0
            kept.append((b[0] + (a[0] - b[0]) * t, b[1] + (a[1] - b[1]) * t))
            break
        kept.append(a)
        left -= step
    return kept[::-1]
