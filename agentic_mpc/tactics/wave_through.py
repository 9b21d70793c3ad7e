"""Rule ``wave_through``: inside a junction, a car standing in the ego's way while the ego stands too is waved on.

The face-to-face wait it ends: an OpenStreetMap cluster's internal lane can make a turning car wait for the ego at
a point that lies in the ego's own path (``junction_osm_route``, cluster 1560223815...: the end of the waiting
car's first internal lane is 0.9 m from the centre of the ego's left turn). The car gives way to the ego, J0 keeps
the ego's body out of the car's, and both stand for good (five of twenty unseen seeds stood until the run's end).
A driver in the ego's place waves the other car on: once the ego has stood ``wave_through.after_s`` with a standing
car reaching into its path within ``wave_through.within_m`` ahead, the plan names that car
(:attr:`~agentic_mpc.tactics.layer.TacticalPlan.wave_through`) and the world tells its driver to go first (SUMO:
it stops giving way to the ego at junctions until it has left this one). The ego then stands until that car is out
of its way (:meth:`WaveThrough.hold`): a stop at its front, as the junction rules' stop at a line.

Only cars off the ego's lanes (crossing, turning in, oncoming) are waved: one ahead on the ego's own lane is a
leader, not a car waiting for the ego. Never while the junction rules hold the ego at a line (a red light, giving
way): that wait is the ego's, not a mutual one. The same geometry keeps a standing ego from setting off while a car
moves across its path (:meth:`WaveThrough.crossing`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from agentic_mpc.tactics.config import TacticsConfig
from agentic_mpc.tactics.road import TacticalRoad
from agentic_mpc.world.observation import Observation, VehicleObservation

NEAR_LINE_M = 5.0
"""The ego waves only in a junction: its front past the stop line of one, or this close to it; and never while
the junction rules stop it at a line this close (a stop further ahead, a red light 74 m on, does not hold it)."""
LEADER_CLEAR_M = 2.0
"""A waved car that has turned into the ego's lane is out of its way once this far ahead (bumper to bumper):
alongside, still turning, its rear swings across the ego's lane (tuning seed 312: the ego, let go as soon as the
car's centre was on its lane, touched its rear)."""


@dataclass(frozen=True, slots=True)
class Waved:
    """A car the ego waved through: which, in which junction, when."""

    vehicle_id: str
    junction_id: str
    time_s: float

    def describe(self) -> str:
        return f"waved {self.vehicle_id} through at junction {self.junction_id}: waiting for it to go first"


class WaveThrough:
    """The rule's state over a run: since when the ego has stood with the same car in its way."""

    def __init__(self, config: TacticsConfig) -> None:
        self.config = config
        self._blocker: tuple[str, float] | None = None  # (the standing car in the ego's way, since when)
        self.last: Waved | None = None
        self.holding = False
        """Whether the ego waits for the car it waved on (:meth:`hold`)."""

    def decide(self, observation: Observation, road: TacticalRoad, lane: int | None, held_at_line: bool
               ) -> Waved | None:
        """The car to wave through this step (once per car), or None. ``lane``: the lane J1 follows."""
        rule = self.config.wave_through
        ego = observation.ego
        if (lane is None or not self._in_force(road) or held_at_line or self.holding
                or ego.speed_mps > rule.standing_mps):
            self._blocker = None
            return None
        junction = next((j for j in observation.junctions_ahead if j.distance_m <= NEAR_LINE_M), None)
        blocker = self._in_the_way(observation, road, lane) if junction is not None else None
        if blocker is None:
            self._blocker = None
            return None
        if self._blocker is None or self._blocker[0] != blocker.id:
            self._blocker = (blocker.id, observation.time_s)
        if observation.time_s - self._blocker[1] < rule.after_s or (self.last and self.last.vehicle_id == blocker.id):
            return None
        self.last = Waved(blocker.id, junction.junction_id, observation.time_s)
        self.holding = True
        return self.last

    def hold(self, observation: Observation, road: TacticalRoad, lane: int | None) -> bool:
        """Whether the ego still waits for the car it waved on: while that car, off the ego's lanes (or beside the
        ego in its lane, still turning) within reach of the ego, moves or stands in the ego's path. A U-turning
        car's body swings across the ego's path (tuning seed 312); a waved truck stood 10 s more, then set off
        across the ego, which a release after 3 s of standing had let go (tuning seed 518). One that stands
        beside the path lets the ego go."""
        if not self.holding or self.last is None:
            return False
        rule, ego = self.config.wave_through, observation.ego
        car = next((v for v in observation.traffic if v.id == self.last.vehicle_id), None)
        if (car is None or lane is None or car.lane_s_m is not None and car.relation == "ahead" and car.gap_m > (
                LEADER_CLEAR_M) or not self._within_reach(car, ego, road)):
            self.holding = False  # gone, clear ahead in the ego's lane (a leader now) or out of its way
        elif car.speed_mps <= rule.standing_mps and car.lane_s_m is None and not self._blocks(
                car, observation, road, lane):
            self.holding = False  # it stands beside the ego's path
        return self.holding

    def crossing(self, observation: Observation, road: TacticalRoad, lane: int | None) -> VehicleObservation | None:
        """A car moving across the ego's path (:meth:`_blocks`) while the ego stands on a route with junctions: the
        ego does not set off until it has gone. J0 alone let the ego creep at 0.6 m/s into the rear of an
        oncoming car that made a U-turn in front of it just past a junction (tuning seed 508, when a body was still
        predicted along its lane's tangent, not cutting the corner as SUMO turns it)."""
        ego, rule = observation.ego, self.config.wave_through
        if (lane is None or not self._in_force(road) or ego.speed_mps > rule.standing_mps
                or not observation.junctions_ahead):
            return None
        return next((v for v in observation.traffic
                     if v.speed_mps > rule.standing_mps and (v.lane_s_m is None or v.relation == "alongside")
                     and self._within_reach(v, ego, road) and self._blocks(v, observation, road, lane)), None)

    def _in_the_way(self, observation: Observation, road: TacticalRoad, lane: int) -> VehicleObservation | None:
        """The nearest standing car off the ego's lanes that :meth:`_blocks` the ego's path."""
        ego, rule = observation.ego, self.config.wave_through
        nearest: tuple[float, VehicleObservation] | None = None
        for vehicle in observation.traffic:
            if (vehicle.lane_s_m is not None or vehicle.speed_mps > rule.standing_mps
                    or not self._within_reach(vehicle, ego, road)):
                continue
            distance = math.hypot(vehicle.x_m - ego.x_m, vehicle.y_m - ego.y_m)
            if (nearest is None or distance < nearest[0]) and self._blocks(vehicle, observation, road, lane):
                nearest = (distance, vehicle)
        return nearest[1] if nearest else None

    def _in_force(self, road: TacticalRoad) -> bool:
        """The rule is in force and the world gives the road's shape (``TacticalRoad.locate``)."""
        return self.config.uses("wave_through") and road.locate is not None

    def _within_reach(self, vehicle: VehicleObservation, ego: Any, road: TacticalRoad) -> bool:
        """Whether the car's centre is within ``within_m`` of the ego's front plus its half length."""
        reach = self.config.wave_through.within_m + 0.5 * (road.ego_length_m + vehicle.length_m)
        return math.hypot(vehicle.x_m - ego.x_m, vehicle.y_m - ego.y_m) <= reach

    def _blocks(self, vehicle: VehicleObservation, observation: Observation, road: TacticalRoad, lane: int) -> bool:
        """Whether the car's body reaches into the ego's path (its width and the clearance margin each side of the
        lane's centre line) within ``within_m`` ahead of the ego's front."""
        from shapely import Polygon, box  # only when the ego stands in a junction

        ego = observation.ego
        front_s = ego.road_s_m + 0.5 * road.ego_length_m
        half = 0.5 * road.ego_width_m + road.clearance_margin_m
        centre = road.lane_centres_m[lane]
        path = box(front_s, centre - half, front_s + self.config.wave_through.within_m, centre + half)
        guess = ego.road_s_m + math.hypot(vehicle.x_m - ego.x_m, vehicle.y_m - ego.y_m)
        return bool(Polygon([road.locate(x, y, guess) for x, y in _corners(vehicle)]).intersects(path))


def _corners(vehicle: VehicleObservation) -> list[tuple[float, float]]:
    c, s = math.cos(vehicle.heading_rad), math.sin(vehicle.heading_rad)
    a, b = 0.5 * vehicle.length_m, 0.5 * vehicle.width_m
    return [(vehicle.x_m + i * a * c - j * b * s, vehicle.y_m + i * a * s + j * b * c)
            for i, j in ((1, 1), (1, -1), (-1, -1), (-1, 1))]
