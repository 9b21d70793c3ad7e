"""Turns the SUMO bridge's raw records into the world's :class:`~agentic_mpc.world.observation.Observation`.

Positions arrive converted by the bridge (centres, radians from +x); this adds the along-road view relative
to the ego (see the observation module for the quantities) and our own footprint-overlap collision check.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Sequence

from agentic_mpc.polylines.kernels import locate
from agentic_mpc.sumo.bridge import VehicleInfo, VehicleState
from agentic_mpc.sumo.network import Road
from agentic_mpc.world.collisions import boxes_overlap, footprint_gap_m
from agentic_mpc.world.observation import (
    CollisionObservation,
    EgoObservation,
    EmergencyVehicleObservation,
    Observation,
    ObstacleObservation,
    Relation,
    VehicleObservation,
)


class ObservationBuilder:
    """Turns the bridge's raw records into an :class:`Observation` relative to the ego on ``road``."""

    def __init__(
        self,
        road: Road,
        ego_id: str,
        info: Callable[[str], VehicleInfo],
        obstacle_ids: Iterable[str] = (),
        obstacle_poses: Callable[[str], VehicleState | None] | None = None,
        centre_lateral: bool = True,
    ) -> None:
        self.road = road
        self.ego_id = ego_id
        self.info = info
        self.obstacle_order = tuple(dict.fromkeys(obstacle_ids))
        """The scenario's order: observations list obstacles in it (a set's order changes with the process's
        string hashing, and with it the order of J2's obstacles and which one ``obstacle_side`` reports)."""
        self.obstacle_ids = frozenset(self.obstacle_order)
        self._obstacle_poses = obstacle_poses
        self.centre_lateral = centre_lateral
        """A vehicle's lateral offset: its centre's (True) or SUMO's lateral position, its front's (False)."""
        self._position_in_order = {lane: i for i, lane in enumerate(road.left_to_right)}
        self._lane_ids = {span.lane_id for span in road.spans.values()}
        self._known: dict[str, tuple[VehicleInfo, float, float]] = {}  # see _sizes
        # Per SUMO lane of the road, everything the per-vehicle loop needs, in one dict lookup:
        # (road lane index, start on its path, geometry factor, role, edge id, position left to right).
        self._lanes = {
            span.lane_id: (
                span.road_lane_index, span.start_s_m, span.geometry_factor, road.lane_role(span.road_lane_index),
                span.lane_id.rsplit("_", 1)[0], self._position_in_order[span.road_lane_index],
            )
            for span in road.spans.values()
        }

    # --- helpers -------------------------------------------------------------------------------------
    def _sizes(self, vehicle_id: str) -> tuple[VehicleInfo, float, float]:
        """(info, half length, diagonal) of a vehicle: they do not change while it drives."""
        info = self.info(vehicle_id)
        return info, 0.5 * info.length_m, math.hypot(info.length_m, info.width_m)

    def _edge(self, lane_id: str) -> str:
        return lane_id.rsplit("_", 1)[0] if lane_id else ""

    def _role(self, lane_id: str, lane_index: int) -> str:
        lane = self._lanes.get(lane_id)
        return lane[3] if lane is not None else ""

    def _relative_lane(self, ego_lane: int | None, lane_id: str, lane_index: int) -> int | None:
        lane = self._lanes.get(lane_id)
        if ego_lane is None or lane is None:
            return None
        # positive = to the left: the left-to-right position decreases to the left
        return self._position_in_order[ego_lane] - lane[5]

    def _road_s(self, state: VehicleState, length_m: float) -> tuple[float, float | None]:
        """(road_s of the centre, lane_s of the centre or None off the road)."""
        located = self.road.lane_s(state.lane_id, state.lane_pos_m) if state.lane_id else None
        if located is None:
            return float(self.road.road_s(state.x_m, state.y_m)[0]), None
        index, front_s = located
        lane_s = front_s - 0.5 * length_m
        return self.road.lane_to_road_s(index, lane_s), lane_s

    @staticmethod
    def _relation(offset_m: float, gap_m: float) -> Relation:
        if gap_m < 0.0:
            return "alongside"
        return "ahead" if offset_m > 0.0 else "behind"

    def _along_speed(self, state: VehicleState, road_s_m: float) -> float:
        tx, ty = self.road.reference_table.tangent(road_s_m)
        return state.speed_mps * (math.cos(state.heading_rad) * tx + math.sin(state.heading_rad) * ty)

    def _ego_position(self, ego: VehicleState, length_m: float) -> tuple[float, float]:
        """(road_s, lateral offset from its lane's centre line) of the ego's centre, projected exactly."""
        road = self.road
        if ego.lane_id in self._lane_ids:
            index, front_s = road.lane_s(ego.lane_id, ego.lane_pos_m)
            lane_guess = front_s - 0.5 * length_m
            road_s, _ = locate(road.reference_table, ego.x_m, ego.y_m, road.lane_to_road_s(index, lane_guess))
            _, lateral = locate(road.lane_tables[index], ego.x_m, ego.y_m, lane_guess)
            return road_s, lateral
        return float(road.road_s(ego.x_m, ego.y_m)[0]), float(road.lateral_from_reference(ego.x_m, ego.y_m)[0])

    # --- building ------------------------------------------------------------------------------------
    def build(
        self,
        time_s: float,
        ego: VehicleState,
        others: Sequence[VehicleState],
        emergency: Sequence[VehicleState],
        collisions: Sequence[CollisionObservation],
    ) -> Observation:
        road = self.road
        ego_info = self.info(ego.id)
        on_road = ego.lane_id in self._lane_ids
        ego_lane = self._lanes[ego.lane_id][0] if on_road else None
        ego_s, lateral = self._ego_position(ego, ego_info.length_m)
        ego_obs = EgoObservation(
            ego.id, ego.x_m, ego.y_m, ego.heading_rad, ego.speed_mps, ego.lane_id,
            ego_lane if ego_lane is not None else ego.lane_index,  # the road's index (a route's: 0), else SUMO's
            self._role(ego.lane_id, ego.lane_index), self._edge(ego.lane_id), ego_s, lateral,
            ego_info.length_m, ego_info.width_m,
        )
        ego_half = 0.5 * ego_info.length_m
        # The first test of our footprint check (boxes_overlap's): the centres farther apart than half the
        # two diagonals cannot touch. Done here, in the loop, so that only the near few get the full test.
        ego_diagonal, ego_x, ego_y = math.hypot(ego_info.length_m, ego_info.width_m), ego.x_m, ego.y_m

        traffic: list[VehicleObservation] = []
        near: list[VehicleObservation] = []
        obstacles: dict[str, ObstacleObservation] = {}
        # The hot loop (every vehicle in range, every step): locals and one lane lookup per vehicle.
        lanes, known, obstacle_ids = self._lanes, self._known, self.obstacle_ids
        to_road_s, lane_tables, centre_lateral = road.lane_to_road_s, road.lane_tables, self.centre_lateral
        ego_order = lanes[ego.lane_id][5] if on_road else None
        cos, sin = math.cos, math.sin
        for state in others:
            vehicle_id, x, y, heading, speed, lane_id, lane_index, lane_pos, lateral_offset, next_edge, accel = state
            sizes = known.get(vehicle_id)
            if sizes is None:
                sizes = known[vehicle_id] = self._sizes(vehicle_id)
            info, half, diagonal = sizes
            lane = lanes.get(lane_id)
            if lane is None:  # off the road (or on another road): project the position
                s, lane_s, role, edge, relative = self._road_s(state, info.length_m)[0], None, "", \
                    self._edge(lane_id), None
            else:
                index, start, factor, role, edge, order = lane
                lane_index = index  # the road's (on a route SUMO's index on the edge differs)
                lane_s = start + lane_pos * factor - half
                if centre_lateral:  # SUMO's is the front's; the centre sits off it by half the length x the angle
                    lateral_offset = locate(lane_tables[index], x, y, lane_s)[1]
                s = to_road_s(index, lane_s)
                relative = None if ego_order is None else ego_order - order
            offset = s - ego_s
            gap = (offset if offset > 0.0 else -offset) - half - ego_half
            relation = "alongside" if gap < 0.0 else ("ahead" if offset > 0.0 else "behind")
            if vehicle_id in obstacle_ids:
                obstacles[vehicle_id] = ObstacleObservation(
                    vehicle_id, info.type_id, x, y, heading, info.length_m, info.width_m,
                    lane_id, lane_index, role, s, offset, gap, relation, relative,
                )
                continue
            vehicle = VehicleObservation(
                vehicle_id, info.type_id, info.vclass, x, y, heading, speed, speed * cos(heading),
                speed * sin(heading), lane_id, lane_index, role, edge, info.length_m, info.width_m, s, offset, gap,
                relation, relative, lane_s, lateral_offset, next_edge, accel,
            )
            traffic.append(vehicle)
            reach = 0.5 * (ego_diagonal + diagonal)
            if not (ego_x - x) ** 2 + (ego_y - y) ** 2 > reach * reach:
                near.append(vehicle)
        # Obstacles beyond sensing range are still known (they do not move): the agent may plan for them.
        if self._obstacle_poses is not None and self.obstacle_ids:
            for obstacle_id in (i for i in self.obstacle_order if i not in obstacles):
                state = self._obstacle_poses(obstacle_id)
                if state is None:
                    continue
                info = self.info(obstacle_id)
                s, _ = self._road_s(state, info.length_m)
                offset = s - ego_s
                gap = abs(offset) - 0.5 * info.length_m - ego_half
                obstacles[obstacle_id] = ObstacleObservation(
                    obstacle_id, info.type_id, state.x_m, state.y_m, state.heading_rad, info.length_m,
                    info.width_m, state.lane_id, state.lane_index, self._role(state.lane_id, state.lane_index), s,
                    offset, gap, self._relation(offset, gap),
                    self._relative_lane(ego_lane, state.lane_id, state.lane_index),
                )

        emergency_obs = []
        by_id = {v.id: v for v in traffic} if emergency else {}
        ego_along = self._along_speed(ego, ego_s) if emergency else 0.0
        for state in emergency:
            vehicle = by_id.get(state.id)
            if vehicle is None:
                info = self.info(state.id)
                s, lane_s = self._road_s(state, info.length_m)
                offset = s - ego_s
                gap = abs(offset) - 0.5 * info.length_m - ego_half
                lateral = state.lateral_offset_m
                if self.centre_lateral and lane_s is not None:  # as the traffic's (the hot loop above)
                    lateral = locate(road.lane_tables[self._lanes[state.lane_id][0]], state.x_m, state.y_m, lane_s)[1]
                vehicle = VehicleObservation(
                    state.id, info.type_id, info.vclass, state.x_m, state.y_m, state.heading_rad, state.speed_mps,
                    state.speed_mps * math.cos(state.heading_rad), state.speed_mps * math.sin(state.heading_rad),
                    state.lane_id, state.lane_index, self._role(state.lane_id, state.lane_index),
                    self._edge(state.lane_id), info.length_m, info.width_m, s, offset, gap,
                    self._relation(offset, gap), self._relative_lane(ego_lane, state.lane_id, state.lane_index),
                    lane_s, lateral, state.next_edge_id, state.accel_mps2,
                )
            along = self._along_speed(state, vehicle.road_s_m)
            # d|offset|/dt = sign(offset) * (v_other - v_ego) along the road; closing is its negative.
            closing = -math.copysign(1.0, vehicle.offset_m) * (along - ego_along)
            distance = max(0.0, vehicle.gap_m)
            emergency_obs.append(
                EmergencyVehicleObservation(
                    vehicle, vehicle.relation, distance, closing,
                    distance / closing if closing > 1e-6 else None,
                    vehicle.relative_lane == 0,
                )
            )
        emergency_obs.sort(key=lambda e: e.distance_m)

        collision_obs = []
        for c in collisions:
            # SUMO's report measured against the footprints (it checks in lane coordinates: see CollisionObservation).
            gap = math.nan
            if self.ego_id in (c.collider, c.victim):
                other_id = c.victim if c.collider == self.ego_id else c.collider
                other = (next((v for v in traffic if v.id == other_id), None) or obstacles.get(other_id)
                         or next((e.vehicle for e in emergency_obs if e.vehicle.id == other_id), None))
                gap = math.nan if other is None else footprint_gap_m(ego_obs, other)
            collision_obs.append(dataclasses.replace(c, involves_ego=self.ego_id in (c.collider, c.victim),
                                                     footprint_gap_m=gap))
        # Our own footprint check against every vehicle and obstacle: SUMO misses the ego's part in the next
        # lane (it reports only once the ego's centre is across the line).
        reported = {frozenset((c.collider, c.victim)) for c in collision_obs}
        obstacles = {i: obstacles[i] for i in self.obstacle_order if i in obstacles}
        for other in (*near, *obstacles.values()):  # the rest of the traffic is out of reach (above)
            if reported and frozenset((self.ego_id, other.id)) in reported:
                continue
            if boxes_overlap(ego_obs, other):
                speed = getattr(other, "speed_mps", 0.0)
                collision_obs.append(
                    CollisionObservation(
                        self.ego_id, other.id, ego_info.type_id, other.type_id, ego.speed_mps, speed, "overlap",
                        ego.lane_id, ego.lane_pos_m, True, "geometry", 0.0,
                    )
                )
        return Observation(
            time_s, ego_obs, tuple(traffic), tuple(emergency_obs), tuple(obstacles.values()), tuple(collision_obs)
        )
