"""The SUMO world: SUMO (libsumo) drives everybody else, our bicycle model drives the ego.

One :meth:`SumoWorld.advance` (time t -> t + dt) with the controller's inputs:

1. advance our bicycle model (``agentic_mpc.vehicle.step``): the plant is ours, not SUMO's;
2. push the ego's new pose and speed into SUMO (``moveToXY`` with x, y kept exactly; the bridge converts
   centre -> front bumper and heading -> navigational angle, and writes our speed after the step);
3. let SUMO step: its traffic reacts to the ego, collisions are collected;
4. observe: the :class:`~agentic_mpc.world.observation.Observation` at t + dt, the ego where our model put it.

On any failure SUMO is closed and :class:`~agentic_mpc.world.base.WorldError` is raised; the last
observation stays readable.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from agentic_mpc import vehicle
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import Circle, Surroundings
from agentic_mpc.sumo.bridge import SumoBridge, SumoError, VehicleState
from agentic_mpc.sumo.config import LaneRef, SumoConfig
from agentic_mpc.sumo.insertion import insert_at_free_gap, speed_behind_leader
from agentic_mpc.sumo.intention import IntentionReader
from agentic_mpc.sumo.junctions import RouteJunctions
from agentic_mpc.sumo.network import NetworkError, Road, RoadNetwork
from agentic_mpc.sumo.observations import ObservationBuilder
from agentic_mpc.sumo.outline import EgoOutline
from agentic_mpc.sumo.placement import Placement, place_on_road, place_on_route
from agentic_mpc.sumo.road_readings import RoadReadings
from agentic_mpc.sumo.route_files import RouteFileError, read_route_types, rescue_lanes_active, type_attribute
from agentic_mpc.sumo.route_planner import SumoRoutePlanner, has_choices
from agentic_mpc.sumo.start import open_bridge
from agentic_mpc.sumo.surroundings import SurroundingsBuilder
from agentic_mpc.tactics.covers import obstacle_circles
from agentic_mpc.tactics.layer import TacticalPlan, TacticalRoad
from agentic_mpc.vehicle import VEHICLE_MODELS, VehicleParams
from agentic_mpc.world.base import WorldError, WorldReadings
from agentic_mpc.world.observation import Observation

_RELEASE_EVERY_STEPS = 25  # drivers released from a rescue lane once a second at 0.04 s


class SumoWorld(RoadReadings, WorldReadings):
    """A :class:`~agentic_mpc.world.base.World` simulated by SUMO. ``seed`` is SUMO's seed (the run's)."""

    def __init__(self, config: SumoConfig, seed: int = 0, params: VehicleParams | None = None) -> None:
        self.config = config
        self.seed = seed
        self.params = params if params is not None else VEHICLE_MODELS[config.vehicle_model]
        """The ego's plant; the run loop gives the controller the same."""
        self.dt_s = self.params.dt_s
        self._bridge: SumoBridge | None = None
        self._sumo_steps = 0
        self._asked: set[str] = set()  # followers asked to open a gap for the ego in the last cycle
        self._observation: Observation | None = None
        self._next_road: Road | None = None
        self.junctions: RouteJunctions | None = None
        """The junctions of the route (set once SUMO runs)."""
        self.road_version = 0
        """Counts the route changes (the run loop then gives the tactics the new road)."""
        if missing := [route_file for route_file in config.route_files if not Path(route_file).is_file()]:
            raise WorldError(f"route file not found: {missing[0]}")
        try:
            self.network = RoadNetwork(config.net_file)
            self.road: Road = self.network.road(config.road)
            self._route_types = read_route_types(config.route_files)
        except (NetworkError, RouteFileError) as error:
            raise WorldError(str(error)) from error
        self.rescue_lanes = rescue_lanes_active(config, self._route_types)
        """Whether SUMO's drivers form rescue lanes in this run (``config.rescue_lanes`` resolved)."""
        self._ego_start = self._resolve(config.ego.edge_id, config.ego.lane, config.ego.pos_m, "ego start")
        self._state = self._initial_state(self._ego_start)
        self.ego_start: dict[str, Any] = {}
        """Where and when SUMO inserted the ego: requested vs actual front-bumper lane position (set-up fact)."""
        for obstacle in config.obstacles:
            self._resolve(obstacle.edge_id, obstacle.lane, obstacle.pos_m, f"obstacle {obstacle.id!r}")
        for spawn in config.vehicles:
            if spawn.route is not None:
                place_on_route(self.network, spawn)
            else:
                self._resolve(spawn.edge_id, spawn.lane, spawn.pos_m, f"vehicle {spawn.id!r}")
        goal = config.goal_s_m if config.goal_s_m is not None else self.road.reference.length_m - 40.0
        if not 0.0 < goal <= self.road.reference.length_m:
            raise WorldError(f"goal_s_m={goal} is not on the road (0..{self.road.reference.length_m:.1f} m)")
        self.goal_s_m = goal
        self._start_sumo()
        try:
            info = self._bridge.info(config.ego_id)
            self.ego_length_m, self.ego_width_m = info.length_m, info.width_m
            self.obstacle_ids = tuple(o.id for o in config.obstacles)
            self._obstacle_states: dict[str, VehicleState] = {}
            self._lane_of_path: dict[int, tuple[Any, int | None]] = {}
            self._surroundings: dict[int, SurroundingsBuilder] = {}
            self._observer = ObservationBuilder(self.road, config.ego_id, self._bridge.info, self.obstacle_ids,
                                                self._obstacle_state, config.centre_lateral_offsets)
            self.junctions = RouteJunctions(self.road, self._bridge)
            self.route_planner = SumoRoutePlanner(self) if has_choices(self.road) else None
            """Turns and destinations for the agent's tools (:mod:`agentic_mpc.world.routes`)."""
            self._observation = self._observe()
            self._intention = IntentionReader(self.road, self.ego_width_m, max_decel_mps2=config.announce_max_decel_mps2
                                              ) if config.announce_lane_changes else None
            self._outline = EgoOutline(self.road, info, self._bridge, config.ego_id, self._route_from(
                self._ego_start.edge_id)) if config.show_ego_outline and (config.sublane or self.rescue_lanes) else None
        except SumoError as error:
            self.close()
            raise WorldError(f"SUMO world set-up failed: {error}") from error
        except BaseException:
            self.close()
            raise

    # --- set-up --------------------------------------------------------------------------------------
    def _resolve(self, edge_id: str | None, lane: LaneRef, pos_m: float, what: str) -> Placement:
        return place_on_road(self.road, self.network, edge_id, lane, pos_m, what)

    def _initial_state(self, start: Placement, speed_mps: float | None = None) -> np.ndarray:
        """Centre pose of the ego's start (front at pos_m, lateral_offset_m aside), at speed_mps or as configured."""
        x_front, y_front, phi = self.road.pose_on_lane(f"{start.edge_id}_{start.lane_index}", start.pos_m)
        ego_length = self._type_attribute(self.config.ego_type_id, "length", 5.0)
        offset = self.config.ego.lateral_offset_m
        x = x_front - 0.5 * ego_length * math.cos(phi) - offset * math.sin(phi)
        y = y_front - 0.5 * ego_length * math.sin(phi) + offset * math.cos(phi)
        if not self.road.contains(x, y):
            raise WorldError(
                f"ego start is off the road: centre ({x:.2f}, {y:.2f}) with lateral offset {offset} m is outside"
                f" the carriageway ({self.road.width_m:.2f} m wide)"
            )
        return np.array([x, y, phi, self.config.ego.speed_mps if speed_mps is None else speed_mps])

    def _type_attribute(self, type_id: str, name: str, default: float) -> float:
        """A vType's attribute from the route files (before SUMO runs), else SUMO's ``default``."""
        try:
            return type_attribute(self.config.route_files, type_id, name, default)
        except RouteFileError as error:
            raise WorldError(str(error)) from error

    def _route_from(self, edge_id: str) -> str:
        """The id of a SUMO route along the road from ``edge_id`` to its end (added once)."""
        route_id = f"road_from_{edge_id}"
        if route_id not in self._routes:
            self._bridge.add_route(route_id, self.road.edge_ids[self.road.edge_ids.index(edge_id):])
            self._routes.add(route_id)
        return route_id

    def _start_sumo(self) -> None:
        c = self.config
        try:
            self._bridge = open_bridge(c, self.seed, self.dt_s, self.network.lefthand, self._route_types)
        except SumoError as error:
            raise WorldError(str(error)) from error
        try:
            self._routes: set[str] = set()
            for obstacle in c.obstacles:
                r = self._resolve(obstacle.edge_id, obstacle.lane, obstacle.pos_m, obstacle.id)
                self._bridge.add_stopped_vehicle(
                    obstacle.id, self._route_from(r.edge_id), obstacle.type_id,
                    edge_id=r.edge_id, lane_index=r.lane_index, pos_m=r.pos_m,
                )
            # The ego is added before the scenario's vehicles (SUMO inserts in that order), so they, not the
            # ego, wait if their spot is not free; with a warm-up they are part of the traffic the ego meets.
            if c.warmup_s > 0.0:
                self._add_spawns()
                for _ in range(round(c.warmup_s / self.dt_s)):
                    self._step_sumo()
            start = self._ego_start
            if c.ego.match_leader_within_m is not None:
                on_lane = self._bridge.lane_vehicles(f"{start.edge_id}_{start.lane_index}")
                self._state[3] = speed_behind_leader(on_lane, start.pos_m, c.ego.match_leader_within_m, c.ego.speed_mps)
            self._bridge.add_external_vehicle(
                c.ego_id, self._route_from(start.edge_id), c.ego_type_id, lane_index=start.lane_index,
                pos_m=start.pos_m, speed_mps=float(self._state[3]), wait=False,
            )
            if c.warmup_s == 0.0:
                self._add_spawns()
            self._insert_ego(start)
            self._bridge.subscribe_around(c.ego_id, c.sensing_range_m)
            # Put the ego exactly at our initial state (lateral offset included) before the first control step.
            self._bridge.move_external(c.ego_id, *self._state[:3], speed_mps=float(self._state[3]))
            self._bridge.step()
            present = set(self._bridge.vehicle_ids())
            missing = [o.id for o in c.obstacles if o.id not in present]
            if missing:
                raise SumoError(f"SUMO did not insert the obstacles {missing} (their spot is occupied?)")
            waiting = [v.id for v in c.vehicles if v.depart_s is None and v.id not in present]
            if waiting:  # SUMO inserts them when their spot is free (its insertion rules), not now
                warnings.warn(f"SUMO has not inserted {waiting} yet: no safe room where they start", stacklevel=3)
        except (SumoError, WorldError) as error:
            self.close()
            raise WorldError(f"SUMO world set-up failed: {error}") from error
        except BaseException:
            self.close()
            raise

    def _insert_ego(self, start: Placement) -> None:
        """Wait for SUMO to insert the ego at its requested spot; if that stays occupied (dense traffic after a
        warm-up), try the free gaps of its lane nearest to it. Records the spot in ``ego_start``."""
        c, bridge = self.config, self._bridge
        requested_s = bridge.time_s
        steps = bridge.wait_until_inserted(c.ego_id, max(1, round(c.ego_insert_wait_s / self.dt_s)), withdraw=True)
        pos, speed_mps = start.pos_m, float(self._state[3])
        if steps is None:
            pos = insert_at_free_gap(
                bridge, c.ego_id, self._route_from(start.edge_id), c.ego_type_id, lane_index=start.lane_index,
                lane_id=f"{start.edge_id}_{start.lane_index}", requested_pos_m=start.pos_m,
                lane_length_m=self.network.edge(start.edge_id).getLane(start.lane_index).getLength(),
                length_m=self._type_attribute(c.ego_type_id, "length", 5.0),
                min_gap_m=self._type_attribute(c.ego_type_id, "minGap", 2.5),
                speed_mps=speed_mps, fits=lambda p: self._fits(start, p), wait_steps=round(0.5 / self.dt_s),
            )
            self._state = self._initial_state(Placement(start.edge_id, start.lane_index, pos), speed_mps)
        matched = {"speed_mps": speed_mps} if speed_mps != c.ego.speed_mps else {}  # to the leader it met
        self.ego_start = {"edge_id": start.edge_id, "lane_index": start.lane_index, "requested_pos_m": start.pos_m,
                          "pos_m": pos, "requested_at_s": requested_s, "inserted_at_s": bridge.time_s, **matched}

    def _fits(self, start: Placement, pos_m: float) -> bool:
        """Whether the ego starting at ``pos_m`` on the start lane (with its lateral offset) is on the road."""
        try:
            self._initial_state(Placement(start.edge_id, start.lane_index, pos_m))
        except WorldError:
            return False
        return True

    def _add_spawns(self) -> None:
        for spawn in self.config.vehicles:
            if spawn.route is not None:  # its own way (checked connected at set-up), from its edge on
                route_id, r = f"route_of_{spawn.id}", place_on_route(self.network, spawn)
                self._bridge.add_route(route_id, spawn.route[spawn.route.index(r.edge_id):])
            else:
                r = self._resolve(spawn.edge_id, spawn.lane, spawn.pos_m, spawn.id)
                route_id = self._route_from(r.edge_id)
            self._bridge.add_vehicle(
                spawn.id, route_id, spawn.type_id, lane_index=r.lane_index, pos_m=r.pos_m,
                speed_mps=spawn.speed_mps, depart_s=spawn.depart_s,
            )
            self._bridge.configure_vehicle(
                spawn.id, max_speed_mps=spawn.max_speed_mps, speed_factor=spawn.speed_factor,
                imperfection=spawn.imperfection, lane_change_mode=None if spawn.lane_changes else 0,
            )

    # --- the world interface -------------------------------------------------------------------------
    @property
    def bridge(self) -> SumoBridge:  # for tests and scripts that need more than the observation
        if self._bridge is None:
            raise WorldError("the SUMO world is closed")
        return self._bridge

    @property
    def time_s(self) -> float:
        return self._observation.time_s if self._observation is not None else float("nan")

    @property
    def running(self) -> bool:
        return self._bridge is not None and self._bridge.running

    def obstacle_circles(self, only_in_j2: bool = False) -> tuple[Circle, ...]:
        """J2 circles covering the configured obstacles (as SUMO placed them)."""
        wanted = {o.id for o in self.config.obstacles if o.in_j2 or not only_in_j2}
        return tuple(
            circle
            for obstacle in self.observation.obstacles
            if obstacle.id in wanted
            for circle in obstacle_circles(obstacle, self.ego_length_m, self.ego_width_m)
        )

    def surroundings(self, horizon: int, tracked_path: LanePath | None, plan: TacticalPlan | None = None
                     ) -> Surroundings:
        if plan is not None and self.junctions is not None:  # SUMO's drivers must know the ego stops at a light
            self.junctions.tell_light_stop(self.config.ego_id, plan.stop_line_s_m)
            if plan.wave_through is not None or self.junctions.waved:  # ... and when it lets one of them go first
                self.junctions.let_go_first(self.config.ego_id, plan.wave_through, self.observation.traffic)
        return self._builder(horizon).build(self.observation, self._state, self.lane_index_of(tracked_path), plan)

    @property
    def tactical_road(self) -> TacticalRoad:
        return self._builder(1).tactical_road  # the horizon does not change the road or the covers

    def _builder(self, horizon: int) -> SurroundingsBuilder:
        builder = self._surroundings.get(horizon)
        if builder is None:
            builder = self._surroundings[horizon] = SurroundingsBuilder(
                self.road, self.ego_length_m, self.ego_width_m, horizon, self.dt_s, self.config.surroundings)
        return builder

    def use_route(self, road: Road) -> None:
        """Drive ``road`` (a new route through the edge the ego is on) from the next step (any thread)."""
        self._next_road = road

    def _switch_road(self, road: Road) -> None:
        """The new route between two steps: SUMO's ego follows it, every reading of the road is rebuilt."""
        self._bridge.set_route(self.config.ego_id, road.edge_ids)
        self.road, self._next_road, self.road_version = road, None, self.road_version + 1
        self._observer = ObservationBuilder(
            road, self.config.ego_id, self._bridge.info, self.obstacle_ids, self._obstacle_state,
            self.config.centre_lateral_offsets)
        self._surroundings.clear()
        self._lane_of_path.clear()
        self.junctions = RouteJunctions(road, self._bridge, self.junctions.waved if self.junctions else None)
        if self._intention is not None:
            self._intention = IntentionReader(road, self.ego_width_m, max_decel_mps2=self.config.announce_max_decel_mps2)
        self.goal_s_m = self.config.goal_s_m if self.config.goal_s_m is not None else road.reference.length_m - 40.0

    def advance(self, delta: float, throttle: float, brake: float) -> Observation:
        if not self.running:
            raise WorldError("the SUMO world is closed")
        if self._next_road is not None:
            try:
                self._switch_road(self._next_road)
            except SumoError as error:
                self.close()
                raise WorldError(f"SUMO failed at t={self.time_s:.2f} s changing the route: {error}") from error
        state = self._state
        try:
            new_state = vehicle.step_plant(state, delta, throttle, brake, self.params)
            x, y, phi, speed = new_state.tolist()  # Python floats in one call (indexing costs a scalar each)
            self._bridge.move_external(
                self.config.ego_id, x, y, phi, speed_mps=speed, accel_mps2=(speed - float(state[3])) / self.dt_s,
            )
            if self._outline is not None:
                self._outline.update(x, y, phi, speed, self._observation)
            self._step_sumo()
            self._observation = self._observe()
        except Exception as error:
            self.close()
            raise WorldError(f"SUMO failed at t={self.time_s:.2f} s: {error}") from error
        self._state = new_state
        return self._observation

    def signal_intention(self, planned_xy: np.ndarray) -> None:
        """The ego's plan (its centre over the horizon, (H, 2)): SUMO's drivers told of the lane it enters."""
        if self._intention is None or not self.running:
            return
        intention = self._intention.read(self.observation, planned_xy)
        asked = {request.follower_id for request in intention.requests}
        if asked or self._asked:  # each cycle renews the requests; the followers no longer asked are let go
            try:
                self._bridge.open_gaps(self.config.ego_id, intention.requests, end_for=self._asked - asked)
            except SumoError as error:  # the bridge has closed SUMO
                raise WorldError(f"SUMO failed at t={self.time_s:.2f} s: {error}") from error
        self._asked = asked

    def _step_sumo(self) -> None:
        """One SUMO step; once a second, the drivers' fixes near stopped obstacles (as configured) and with rescue
        lanes, the release of those an emergency vehicle passed (or both stand behind one)."""
        self._bridge.step()
        self._sumo_steps += 1
        if self._sumo_steps % _RELEASE_EVERY_STEPS != 0:
            return
        c, rescue = self.config, self.config.rescue_lanes
        if c.straighten_wedged_after_s is not None and c.obstacles:
            self._bridge.straighten_wedged(c.straighten_wedged_after_s)
        if self.rescue_lanes:
            self._bridge.release_rescue_lanes(rescue.release_behind_m or rescue.reaction_dist_m,
                                              self._route_types.lc_strategic, rescue.release_blocked_within_m)

    def time_loss_s(self, vehicle_id: str) -> float | None:
        return self.bridge.time_loss_s(vehicle_id)

    def close(self) -> None:
        if self._bridge is not None:
            self._bridge.close()

    def __enter__(self) -> SumoWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- helpers -------------------------------------------------------------------------------------
    def _obstacle_state(self, obstacle_id: str) -> VehicleState | None:
        state = self._obstacle_states.get(obstacle_id)
        if state is None and self._bridge is not None and self._bridge.has_vehicle(obstacle_id):
            state = self._bridge.vehicle_state(obstacle_id)
            self._obstacle_states[obstacle_id] = state  # obstacles stand still: read once
        return state

    def _observe(self) -> Observation:
        bridge = self.bridge
        ego, others = bridge.around()
        if ego is None:
            raise SumoError(
                f"the ego {self.config.ego_id!r} is no longer in SUMO at t={bridge.time_s:.2f} s"
                " (it left its route's end or the network)"
            )
        observation = self._observer.build(bridge.time_s, ego, others, bridge.emergency_vehicles(), bridge.collisions)
        if self.junctions.junctions:
            front_s = observation.ego.road_s_m + 0.5 * self.ego_length_m
            observation = dataclasses.replace(observation, junctions_ahead=self.junctions.ahead(front_s))
        return observation
