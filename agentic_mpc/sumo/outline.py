"""The part of the ego that sticks into the next lane, shown to SUMO's drivers as a vehicle of that shape.

The ego is driven by ``moveToXY``: SUMO puts it in the lane its centre is in and does not see the part of its
body beyond that lane's line (``../shared/notes/sumo.md``: a car and a truck drove through an ego held 0.7 m
into their lane). Under the sublane model SUMO's drivers do react to where a vehicle stands inside their lane:
a car at 15 m/s moved 0.4 m aside past a 1.0 m wide vehicle standing at its lane's edge, and changed lanes past
a 1.8 m one (measured, SUMO 1.28, sublane 0.4). So the world puts a vehicle of exactly the protruding part's
size there (:class:`EgoOutline`), moving at the ego's speed, and removes it once the ego is back inside one
lane. The bridge keeps it out of every observation and collision report: contact with the ego's body is the
world's own footprint check (``agentic_mpc.world.collisions``).

Only with the sublane model: without it SUMO's drivers treat any vehicle in their lane as filling it, and would
stop behind a 10 cm protrusion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from agentic_mpc.sumo.network import Road

if TYPE_CHECKING:
    from agentic_mpc.sumo.bridge import SumoBridge, VehicleInfo
    from agentic_mpc.world.observation import Observation

MIN_DEPTH_M = 0.1
"""A protrusion shallower than this is not shown (a sublane is 0.4 m wide)."""
ALONGSIDE_LOOKAHEAD_S = 0.2
"""A vehicle whose front reaches the part within this time (at its speed) counts as alongside it already (the
observation is a step old when the outline is placed)."""
MIN_LENGTH_M = 0.5
"""The outline is at least this long (a corner that just crosses the line)."""


@dataclass(frozen=True, slots=True)
class Protrusion:
    """The ego's body beyond its lane's line, as a box along the road: in ``lane_index``, from ``rear_s_m`` to
    ``front_s_m`` along the road's centre line, between ``inner_m`` (the line) and ``outer_m`` (its deepest
    point), lateral from the road's centre line, positive to the left."""

    lane_index: int
    rear_s_m: float
    front_s_m: float
    inner_m: float
    outer_m: float

    @property
    def depth_m(self) -> float:
        return abs(self.outer_m - self.inner_m)

    @property
    def length_m(self) -> float:
        return max(self.front_s_m - self.rear_s_m, MIN_LENGTH_M)


def _beyond(corners: list[tuple[float, float]], line_m: float, side: float) -> list[tuple[float, float]]:
    """The corners (s, lateral) of the ego's box beyond ``line_m`` on ``side`` (+1 left, -1 right), with the
    points where its sides cross the line: the clipped polygon's vertices."""
    clipped = []
    for (s0, l0), (s1, l1) in zip(corners, corners[1:] + corners[:1], strict=True):
        in0, in1 = side * (l0 - line_m) > 0.0, side * (l1 - line_m) > 0.0
        if in0:
            clipped.append((s0, l0))
        if in0 != in1:
            f = (line_m - l0) / (l1 - l0)
            clipped.append((s0 + f * (s1 - s0), line_m))
    return clipped


def protrusion(corners: list[tuple[float, float]], centre_lateral_m: float,
               lane_bounds_m: tuple[tuple[float, float], ...]) -> Protrusion | None:
    """The part of a box (its corners in order, as (s, lateral)) beyond the lines of the lane its centre is in,
    if at least ``MIN_DEPTH_M`` deep and there is a lane on that side; ``lane_bounds_m``: (left, right) of each
    lane by index. None otherwise (the centre off every lane included)."""
    own = next((i for i, (left, right) in enumerate(lane_bounds_m) if right <= centre_lateral_m < left), None)
    if own is None:
        return None
    left, right = lane_bounds_m[own]
    for line, side in ((left, 1.0), (right, -1.0)):
        outer = max(side * lat for _, lat in corners) * side
        if side * (outer - line) < MIN_DEPTH_M:
            continue
        neighbour = next((i for i, (l, r) in enumerate(lane_bounds_m)
                          if abs((r if side > 0 else l) - line) < 0.05), None)
        if neighbour is None:
            return None
        part = _beyond(corners, line, side)
        along = [s for s, _ in part]
        return Protrusion(neighbour, min(along), max(along), line, outer)
    return None


class EgoOutline:
    """Shows SUMO the protruding part of the ego ``ego_id`` (``ego``: its type's size) after each of its moves
    (:meth:`update`), through the bridge, as the vehicle ``<ego_id>.outline`` of its type on ``route_id``."""

    def __init__(self, road: Road, ego: VehicleInfo, bridge: SumoBridge, ego_id: str, route_id: str) -> None:
        self.road = road
        self.half_length_m, self.half_width_m = 0.5 * ego.length_m, 0.5 * ego.width_m
        self.lane_bounds_m = road.lane_bounds_m
        self.bridge, self.outline_id, self.route_id, self.type_id = bridge, f"{ego_id}.outline", route_id, ego.type_id

    def pose(self, x_m: float, y_m: float, phi_rad: float, observation: Observation
             ) -> tuple[int, float, float, float, float, float] | None:
        """(lane index, centre x, centre y, heading, length, width) of the outline of the ego at this centre pose,
        or None: the ego is inside its lane (or protrudes by less than ``MIN_DEPTH_M``, or over the road's
        edge), or a vehicle in that lane is alongside the part (``observation``: the last one). SUMO's sublane
        model takes a vehicle beside a driver, within its lateral gap, for a leader at a negative gap: a car
        standing beside the ego's nose in a rescue lane never moved again, and the ego waited for it (seed 1212)."""
        road_s_guess_m = observation.ego.road_s_m
        table = self.road.reference_table
        c, s = math.cos(phi_rad), math.sin(phi_rad)
        corners = []
        for along, across in ((self.half_length_m, self.half_width_m), (-self.half_length_m, self.half_width_m),
                              (-self.half_length_m, -self.half_width_m), (self.half_length_m, -self.half_width_m)):
            corners.append(table.locate(x_m + along * c - across * s, y_m + along * s + across * c, road_s_guess_m))
        centre = table.locate(x_m, y_m, road_s_guess_m)[1]
        part = protrusion(corners, centre, self.lane_bounds_m)
        if part is None or any(
                v.lane_index == part.lane_index and v.road_s_m - 0.5 * v.length_m < part.front_s_m
                and v.road_s_m + 0.5 * v.length_m + v.speed_mps * ALONGSIDE_LOOKAHEAD_S > part.rear_s_m
                for v in observation.traffic):
            return None
        mid_s = 0.5 * (part.rear_s_m + part.front_s_m)
        (point,), (tangent,) = table.at([mid_s])
        lateral = 0.5 * (part.inner_m + part.outer_m)
        x, y = point[0] - lateral * tangent[1], point[1] + lateral * tangent[0]
        return part.lane_index, float(x), float(y), math.atan2(tangent[1], tangent[0]), part.length_m, part.depth_m

    def update(self, x_m: float, y_m: float, phi_rad: float, speed_mps: float, observation: Observation) -> None:
        """The ego's new centre pose and speed (before SUMO's step; ``observation``: the last one): the outline
        shown there, or removed."""
        pose = self.pose(x_m, y_m, phi_rad, observation)
        if pose is None:
            self.bridge.hide_outline(self.outline_id)
            return
        _, x, y, heading, length, width = pose
        self.bridge.show_outline(self.outline_id, self.route_id, self.type_id, x_m=x, y_m=y, phi_rad=heading,
                                 length_m=length, width_m=width, speed_mps=speed_mps)
