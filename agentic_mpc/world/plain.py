"""A plain-Python world: a straight road along +x, scripted traffic, static obstacles, no traffic simulator.

For the paper's Scenario 1 without traffic (``scenarios/paper_steering_preference_plain.yaml``), ``serve``
without SUMO, and fast tests. The ego is the paper's vehicle model; the other road users drive along their
lane at a desired speed and slow down behind whoever is ahead in their lane (so an ambulance waits behind the
ego until the ego makes way). Obstacles are circles, given to J2 as they are.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agentic_mpc import vehicle
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import Circle, Leader, MovingDisc, Surroundings, TrackingReference
from agentic_mpc.vehicle import PAPER_PARAMS, VehicleParams
from agentic_mpc.world.base import WorldError, WorldReadings
from agentic_mpc.world.collisions import boxes_overlap
from agentic_mpc.world.lanes import RoadLanes
from agentic_mpc.world.observation import (
    CollisionObservation,
    EgoObservation,
    EmergencyVehicleObservation,
    Observation,
    ObstacleObservation,
    VehicleObservation,
)
from agentic_mpc.world.plain_config import ROLES, PlainConfig, ScriptedVehicle

EGO_LENGTH_M, EGO_WIDTH_M = 4.5, 1.8
EGO_RADIUS_M = 1.5
"""Radius of the disc standing for the ego in J0's discs (collisions use its box)."""
SENSING_RANGE_M = 150.0


class _Mover:
    """A scripted vehicle's changing part."""

    __slots__ = ("spec", "x_m", "speed_mps")

    def __init__(self, spec: ScriptedVehicle, x_m: float) -> None:
        self.spec, self.x_m, self.speed_mps = spec, x_m, spec.desired_speed_mps


class PlainWorld(WorldReadings):
    """A :class:`~agentic_mpc.world.base.World` in plain Python."""

    def __init__(self, config: PlainConfig | None = None, seed: int = 0, params: VehicleParams = PAPER_PARAMS) -> None:
        self.config = c = config or PlainConfig()
        self.seed = seed  # nothing here is random; kept for the interface's symmetry
        self.params = params
        self.dt_s = params.dt_s
        self.road = c.road
        end = c.road.start_x_m + c.road.length_m
        self._lanes = {
            role: LanePath.straight((c.road.start_x_m, c.road.lane_y_m(role)), (end, c.road.lane_y_m(role)), name=role)
            for role in ROLES
        }
        self.goal_s_m = c.goal_s_m if c.goal_s_m is not None else c.road.length_m - 40.0
        if not 0.0 < self.goal_s_m <= c.road.length_m:
            raise WorldError(f"goal_s_m={self.goal_s_m} is not on the road (0..{c.road.length_m} m)")
        if not c.road.start_x_m <= c.ego.x_m <= end:
            raise WorldError(f"the ego's start x_m={c.ego.x_m} is off the road ({c.road.start_x_m}..{end} m)")
        self._state = np.array([c.ego.x_m, c.road.lane_y_m(c.ego.lane), 0.0, c.ego.speed_mps])
        self._step = 0
        self._movers: dict[str, _Mover] = {}
        self._appear(0.0)
        self._observation = self._observe()

    # --- the world interface -------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        return self._step * self.dt_s

    def lanes(self) -> RoadLanes:
        by_index = tuple(sorted(self._lanes.values(), key=lambda path: self.lane_index_of(path)))
        left_to_right = tuple(self.road.index_of(role) for role in ("left", "center", "right"))
        return RoadLanes(dict(self._lanes), self.road.speed_limit_mps, self.road.lefthand, by_index, left_to_right)

    def lane(self, ref: int | str) -> tuple[str, LanePath]:
        role = ref if isinstance(ref, str) else next((r for r in ROLES if self.road.index_of(r) == ref), None)
        if role not in self._lanes:
            raise WorldError(f"road has no lane {ref!r}; it has {list(ROLES)} (indices 0-2)")
        return role, self._lanes[role]

    def lane_index_of(self, path: LanePath | None) -> int | None:
        role = next((r for r, p in self._lanes.items() if p is path or p == path), None)
        return None if role is None else self.road.index_of(role)

    def lateral_offset_m(self, lane_index: int, x_m: float, y_m: float) -> float:
        role = next(r for r in ROLES if self.road.index_of(r) == lane_index)
        return y_m - self.road.lane_y_m(role)

    def obstacle_circles(self, only_in_j2: bool = False) -> tuple[Circle, ...]:
        return tuple(
            Circle(x_m=o.x_m, y_m=o.y_m, radius_m=o.radius_m, label=o.id)
            for o in self.config.obstacles
            if o.in_j2 or not only_in_j2
        )

    def signal_intention(self, planned_xy: np.ndarray) -> None:
        """Its movers keep their speeds whatever the ego does: nobody to tell."""

    def surroundings(self, horizon: int, tracked_path: LanePath | None, plan: Any = None) -> Surroundings:
        x = float(self._state[0])
        k = np.arange(1, horizon + 1)
        discs = tuple(
            MovingDisc(
                np.stack([m.x_m + m.speed_mps * self.dt_s * k, np.full(horizon, self.road.lane_y_m(m.spec.lane))], 1),
                m.spec.radius_m + EGO_RADIUS_M,
            )
            for m in self._movers.values()
            if abs(m.x_m - x) < SENSING_RANGE_M
        )
        tangents = np.tile([1.0, 0.0], (horizon, 1))
        leaders = self._leaders(horizon, tracked_path, tangents)
        if not self.config.road_edges:
            return Surroundings(discs, leaders=leaders)
        ahead = x + max(float(self._state[3]), 1.0) * self.dt_s * k

        def edge(y_m: float) -> TrackingReference:
            return TrackingReference(np.stack([ahead, np.full(horizon, y_m)], axis=1), tangents)

        half = 1.5 * self.road.lane_width_m
        return Surroundings(discs, edge(half), edge(-half), leaders)

    def _leaders(self, horizon: int, tracked_path: LanePath | None, tangents: np.ndarray) -> tuple[Leader, ...]:
        """J0's time gap: the nearest mover ahead on the tracked lane (else the ego's), at constant speed; the
        contact point is where the ego's centre is with its front bumper at the mover's rear."""
        index = self.lane_index_of(tracked_path)
        role = self.road.lane_of(float(self._state[1])) if index is None else self.lane(index)[0]
        x = float(self._state[0])
        ahead = [m for m in self._movers.values()
                 if m.spec.lane == role and m.x_m - m.spec.radius_m - 0.5 * EGO_LENGTH_M > x
                 and m.x_m - x < SENSING_RANGE_M]
        if not ahead:
            return ()
        m = min(ahead, key=lambda mover: mover.x_m)
        contact = m.x_m - m.spec.radius_m - 0.5 * EGO_LENGTH_M + m.speed_mps * self.dt_s * np.arange(1, horizon + 1)
        return (Leader(np.stack([contact, np.full(horizon, self.road.lane_y_m(role))], axis=1), tangents),)

    def advance(self, delta: float, throttle: float, brake: float) -> Observation:
        self._state = vehicle.step_plant(self._state, delta, throttle, brake, self.params)
        self._move_traffic(self.time_s)
        self._step += 1
        self._observation = self._observe()
        return self._observation

    def time_loss_s(self, vehicle_id: str) -> float | None:
        mover = self._movers.get(vehicle_id)
        if mover is None or mover.spec.desired_speed_mps <= 0:
            return None
        # the time it has been driving minus the time its distance would take at its desired speed
        driving_s = self.time_s - mover.spec.appear_at_s
        start = mover.spec.x_m if mover.spec.x_m is not None else mover.x_m  # approximate for late starters
        return max(0.0, driving_s - (mover.x_m - start) / mover.spec.desired_speed_mps)

    def close(self) -> None:
        """Nothing to release."""

    # --- traffic -------------------------------------------------------------------------------------
    def _appear(self, t: float) -> None:
        for spec in self.config.vehicles:
            if spec.id not in self._movers and t >= spec.appear_at_s:
                x = spec.x_m if spec.x_m is not None else float(self._state[0]) - spec.behind_ego_m
                self._movers[spec.id] = _Mover(spec, x)

    def _move_traffic(self, t: float) -> None:
        self._appear(t)
        movers = list(self._movers.values())
        for m in movers:
            y = self.road.lane_y_m(m.spec.lane)
            # The nearest road user ahead in the same lane (the ego included), for a simple gap keeping.
            leaders = [(float(self._state[0]), float(self._state[3]))] if abs(self._state[1] - y) < 2.5 else []
            leaders += [(o.x_m, o.speed_mps) for o in movers if o is not m and o.spec.lane == m.spec.lane]
            leaders = [(x, s) for x, s in leaders if x > m.x_m]
            target = m.spec.desired_speed_mps
            if leaders:
                x_lead, v_lead = min(leaders)
                gap = x_lead - m.x_m - 8.0
                if gap < 10.0 + 1.5 * m.speed_mps:
                    target = min(target, v_lead if gap > 2.0 else 0.0)
            rate = 2.0 if target > m.speed_mps else 6.0
            m.speed_mps += float(np.clip(target - m.speed_mps, -rate * self.dt_s, rate * self.dt_s))
            m.x_m += m.speed_mps * self.dt_s

    # --- observing -----------------------------------------------------------------------------------
    def _along(self, x_m: float, length_m: float, ego_x_m: float) -> tuple[float, float, str]:
        offset = x_m - ego_x_m
        gap = abs(offset) - 0.5 * (length_m + EGO_LENGTH_M)
        return offset, gap, "alongside" if gap < 0.0 else ("ahead" if offset > 0.0 else "behind")

    def _lanes_left_of(self, ego_role: str, role: str) -> int:
        return round((self.road.lane_y_m(role) - self.road.lane_y_m(ego_role)) / self.road.lane_width_m)

    def _observe(self) -> Observation:
        x, y, phi, v = (float(s) for s in self._state)
        road = self.road
        ego_role = road.lane_of(y)
        ego_index = road.index_of(ego_role)
        ego = EgoObservation("ego", x, y, phi, v, ego_role, ego_index, ego_role, "", x - road.start_x_m,
                             y - road.lane_y_m(ego_role), EGO_LENGTH_M, EGO_WIDTH_M)
        traffic, emergency = [], []
        for m in self._movers.values():
            spec, length = m.spec, 2.0 * m.spec.radius_m
            offset, gap, relation = self._along(m.x_m, length, x)
            other = VehicleObservation(
                spec.id, spec.type_id, "emergency" if spec.emergency else "passenger", m.x_m, road.lane_y_m(spec.lane),
                0.0, m.speed_mps, m.speed_mps, 0.0, spec.lane, road.index_of(spec.lane), spec.lane, "", length,
                length, m.x_m - road.start_x_m, offset, gap, relation, self._lanes_left_of(ego_role, spec.lane),
                m.x_m - road.start_x_m, 0.0, "", 0.0,
            )
            if abs(offset) < SENSING_RANGE_M:
                traffic.append(other)
            if spec.emergency:
                closing = -math.copysign(1.0, offset) * (m.speed_mps - v)
                distance = max(0.0, gap)
                emergency.append(EmergencyVehicleObservation(
                    other, relation, distance, closing, distance / closing if closing > 1e-6 else None,
                    other.relative_lane == 0,
                ))
        obstacles = []
        for o in self.config.obstacles:
            role = road.lane_of(o.y_m)
            offset, gap, relation = self._along(o.x_m, 2.0 * o.radius_m, x)
            obstacles.append(ObstacleObservation(
                o.id, "obstacle", o.x_m, o.y_m, 0.0, 2.0 * o.radius_m, 2.0 * o.radius_m, role, road.index_of(role),
                role, o.x_m - road.start_x_m, offset, gap, relation, self._lanes_left_of(ego_role, role),
            ))
        # Vehicles: the shared footprint check (boxes as observed); an obstacle's circle is where the ego's
        # centre must not go (the paper's Scenario 1: J2's circle is the obstacle).
        touching = [t for t in traffic if boxes_overlap(ego, t)]
        touching += [o for o in obstacles if math.hypot(o.x_m - x, o.y_m - y) < 0.5 * o.length_m]
        collisions = [
            CollisionObservation("ego", other.id, "ego", other.type_id, v, getattr(other, "speed_mps", 0.0), "overlap",
                                 ego_role, x - road.start_x_m, True, "geometry", 0.0)
            for other in touching
        ]
        emergency.sort(key=lambda e: e.distance_m)
        return Observation(round(self.time_s, 9), ego, tuple(traffic), tuple(emergency), tuple(obstacles),
                           tuple(collisions))
