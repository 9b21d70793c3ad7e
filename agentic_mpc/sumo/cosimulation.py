"""The co-simulation: our controller and bicycle model drive the ego, SUMO drives everybody else.

One :meth:`CoSimulation.step` (time t -> t + dt):

1. read the observation SUMO gives at t (the ego exactly where our model put it);
2. ``FourierMPPI.step(state, slot.current, surroundings)``: the specification is whatever the agent has
   swapped into the :class:`SpecificationSlot` by now;
3. advance our bicycle model (``agentic_mpc.vehicle.step``): the plant is ours, not SUMO's;
4. push the ego's new pose and speed into SUMO (``moveToXY`` with x, y kept exactly; the bridge converts
   centre -> front bumper and heading -> navigational angle, and writes our speed after the step);
5. let SUMO step: its traffic reacts to the ego, collisions are collected.

Every step is recorded (:class:`StepRecord`), and the records survive a failed run: the run closes SUMO and
raises :class:`CoSimulationError`, while ``records`` keeps what happened until then.
"""

from __future__ import annotations

import math
import time
import warnings
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from agentic_mpc import vehicle
from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import ObstacleAvoidance, PathTracking, Specification, SpecificationSlot
from agentic_mpc.sumo.bridge import SumoBridge, SumoError, VehicleState
from agentic_mpc.sumo.network import NetworkError, Road, RoadNetwork
from agentic_mpc.sumo.observations import CollisionObservation, Observation, ObservationBuilder
from agentic_mpc.sumo.surroundings import SurroundingsBuilder, SurroundingsConfig, obstacle_circles
from agentic_mpc.vehicle import PAPER_PARAMS, VehicleParams

LaneRef = int | Literal["left", "center", "right"]


class CoSimulationError(RuntimeError):
    """A co-simulation that cannot start or that failed during a run (SUMO is closed; records are kept)."""


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class EgoStart(_Frozen):
    """Where the ego enters. Positions are SUMO lane positions of the FRONT bumper, as in SUMO's departPos."""

    edge_id: str | None = Field(None, description="edge of the road to start on (default: the road's first)")
    lane: LaneRef = Field("center", description="lane index or role")
    pos_m: float = Field(30.0, ge=0, description="front-bumper lane position")
    speed_mps: float = Field(15.0, ge=0, le=60)
    lateral_offset_m: float = Field(0.0, description="start this far left (+) of the lane centre")


class _Placed(_Frozen):
    """A vehicle the scenario puts on a lane of the road: which, of what type, where."""

    id: str = Field(..., min_length=1)
    type_id: str
    edge_id: str | None = Field(None, description="edge of the road (default: the road's first)")
    lane: LaneRef = "center"
    pos_m: float = Field(..., ge=0, description="front-bumper lane position")


class VehicleSpawn(_Placed):
    """A SUMO-driven vehicle placed by the scenario (in addition to any traffic in the route files)."""

    type_id: str = "car"
    speed_mps: float = Field(0.0, ge=0)
    depart_s: float | None = Field(None, ge=0, description="insertion time (None: at the start)")
    max_speed_mps: float | None = Field(None, gt=0)
    speed_factor: float | None = Field(None, gt=0)
    imperfection: float | None = Field(None, ge=0, le=1, description="Krauss sigma (0 = perfect driver)")
    lane_changes: bool = Field(True, description="False: SUMO never changes this vehicle's lane")


class StaticObstacle(_Placed):
    """A stopped vehicle on a lane: SUMO traffic drives around or stops behind it, and J2 sees it."""

    type_id: str = "obstacle"
    in_j2: bool = Field(True, description="add it to the initial specification's obstacle avoidance (J2)")


class CoSimConfig(_Frozen):
    """Everything a co-simulation run needs; validated before SUMO starts."""

    net_file: Path
    route_files: tuple[Path, ...] = Field(..., min_length=1, description="must define the vTypes used")
    road: str | tuple[str, ...] = Field(
        ..., description="the ego's road: a start edge (followed while it has one successor) or the edge list"
    )
    seed: int = Field(0, ge=0, description="SUMO's seed")
    controller_seed: int | None = Field(None, ge=0, description="MPPI's seed (default: seed)")
    sublane: bool = Field(False, description="SUMO's sublane model (lateral behaviour, about 10x per step)")
    lateral_resolution_m: float = Field(0.4, gt=0)
    ego: EgoStart = EgoStart()
    ego_id: str = "ego"
    ego_type_id: str = "ego"
    vehicles: tuple[VehicleSpawn, ...] = ()
    obstacles: tuple[StaticObstacle, ...] = ()
    warmup_s: float = Field(0.0, ge=0, description="SUMO runs alone this long before the ego enters")
    v_ref_mps: float = Field(15.0, ge=0, description="reference speed of the default specification's J1")
    goal_s_m: float | None = Field(
        None, description="along-road position that ends run() (default: 40 m before the road's end)"
    )
    sensing_range_m: float = Field(150.0, gt=0)
    keep_route: Literal[2, 3] = Field(3, description="moveToXY keepRoute for the ego (see SumoBridge)")
    mppi: MPPIConfig = MPPIConfig()
    surroundings: SurroundingsConfig = SurroundingsConfig()
    sumo_log_file: Path | None = None
    quiet: bool = Field(True, description="suppress SUMO's warnings on stderr")

    def replace(self, **changes: Any) -> CoSimConfig:
        """A validated copy with ``changes`` (pydantic's ``model_copy(update=...)`` skips validation)."""
        return type(self).model_validate({**dict(self), **changes})

    @field_validator("route_files", mode="before")
    @classmethod
    def _one_or_many(cls, value: Any) -> Any:
        return (value,) if isinstance(value, (str, Path)) else value

    @model_validator(mode="after")
    def _unique_ids(self) -> CoSimConfig:
        ids = [self.ego_id, *(v.id for v in self.vehicles), *(o.id for o in self.obstacles)]
        duplicates = sorted({i for i in ids if ids.count(i) > 1})
        if duplicates:
            raise ValueError(f"vehicle ids must be unique, duplicated: {duplicates}")
        return self


@dataclass(frozen=True, slots=True)
class StepRecord:
    """One co-simulation step: our model's state at t, what SUMO reported at t, the inputs applied at t."""

    time_s: float
    x_m: float
    y_m: float
    phi_rad: float
    v_mps: float
    delta: float
    throttle: float
    brake: float
    sumo_x_m: float
    sumo_y_m: float
    sumo_heading_rad: float
    sumo_speed_mps: float
    """SUMO's speed of the ego: our model's speed, written after each step (see SumoBridge.move_external)."""
    lane_id: str
    lane_index: int
    lane_role: str
    road_s_m: float
    lateral_offset_m: float
    spec_version: int
    spec_summary: str
    cost_min: float
    effective_samples: float
    solve_ms: float
    step_ms: float
    """Wall time of the whole co-simulation step (observation + controller + model + SUMO step)."""
    vehicles_in_range: int
    discs: int
    collisions: int
    """Collisions involving the ego that SUMO or the geometry check reported at t."""

    @property
    def position_error_m(self) -> float:
        return math.hypot(self.x_m - self.sumo_x_m, self.y_m - self.sumo_y_m)


@dataclass(frozen=True, slots=True)
class RunSummary:
    steps: int
    time_s: float
    reached_goal: bool
    ego_collisions: int
    collisions: int
    max_position_error_m: float


@dataclass
class _Resolved:
    """Config positions resolved against the network."""

    edge_id: str
    lane_index: int
    pos_m: float


class CoSimulation:
    """Owns the SUMO bridge, the plant state, the controller and the specification slot of one run.

    ``specification`` (or ``slot``, when an agent shares it) sets what the controller optimises; the default
    is J1 on the ego's start lane at ``v_ref_mps`` (+ J2 on the configured obstacles).
    """

    def __init__(
        self,
        config: CoSimConfig,
        specification: Specification | None = None,
        *,
        slot: SpecificationSlot | None = None,
        params: VehicleParams = PAPER_PARAMS,
    ) -> None:
        if specification is not None and slot is not None:
            raise ValueError("give a specification or a slot, not both")
        self.config = config
        self.params = params
        self.records: list[StepRecord] = []
        self.collisions: list[CollisionObservation] = []
        self.observation: Observation | None = None
        self.error: BaseException | None = None
        self._bridge: SumoBridge | None = None

        for route_file in config.route_files:
            if not Path(route_file).is_file():
                raise CoSimulationError(f"route file not found: {route_file}")
        try:
            self.network = RoadNetwork(config.net_file)
            self.road: Road = self.network.road(config.road)
        except NetworkError as error:
            raise CoSimulationError(str(error)) from error
        ego_start = self._resolve(config.ego.edge_id, config.ego.lane, config.ego.pos_m, "ego start")
        self._ego_start = ego_start
        self.state = self._initial_state(ego_start)
        for obstacle in config.obstacles:
            self._resolve(obstacle.edge_id, obstacle.lane, obstacle.pos_m, f"obstacle {obstacle.id!r}")
        for spawn in config.vehicles:
            self._resolve(spawn.edge_id, spawn.lane, spawn.pos_m, f"vehicle {spawn.id!r}")
        goal = config.goal_s_m if config.goal_s_m is not None else self.road.reference.length_m - 40.0
        if not 0.0 < goal <= self.road.reference.length_m:
            raise CoSimulationError(f"goal_s_m={goal} is not on the road (0..{self.road.reference.length_m:.1f} m)")
        self.goal_s_m = goal

        self.controller = FourierMPPI(config.mppi, params, seed=config.seed if config.controller_seed is None
                                      else config.controller_seed)
        mean = np.zeros((2, config.mppi.coefficients))
        mean[1, 0] = vehicle.throttle_for_steady_speed(config.ego.speed_mps, params)
        self.controller.reset(mean)

        self._start_sumo()
        try:
            self.ego_length_m = self._bridge.info(config.ego_id).length_m
            self.ego_width_m = self._bridge.info(config.ego_id).width_m
            self.obstacle_ids = tuple(o.id for o in config.obstacles)
            self._obstacle_states: dict[str, VehicleState] = {}
            self._lane_of_path: dict[int, tuple[Any, int | None]] = {}
            self._observer = ObservationBuilder(
                self.road, config.ego_id, self._bridge.info, self.obstacle_ids, self._obstacle_state
            )
            self._surroundings = SurroundingsBuilder(
                self.road, self.ego_length_m, self.ego_width_m, config.mppi.horizon, params.dt_s, config.surroundings
            )
            self.observation = self._observe()
            self.collisions.extend(self.observation.collisions)
            self.slot = slot if slot is not None else SpecificationSlot(specification or self.default_specification())
        except SumoError as error:
            self.close()
            raise CoSimulationError(f"co-simulation set-up failed: {error}") from error
        except BaseException:
            self.close()
            raise

    # --- set-up --------------------------------------------------------------------------------------
    def _resolve(self, edge_id: str | None, lane: LaneRef, pos_m: float, what: str) -> _Resolved:
        edge_id = edge_id or self.road.edge_ids[0]
        if edge_id not in self.road.edge_ids:
            raise CoSimulationError(f"{what}: edge {edge_id!r} is not on the road {list(self.road.edge_ids)}")
        try:
            index = self.road.lane_index(lane)
        except NetworkError as error:
            raise CoSimulationError(f"{what}: {error}") from error
        length = self.network.edge(edge_id).getLane(index).getLength()
        if not 0.0 <= pos_m <= length:
            raise CoSimulationError(
                f"{what} is off the road: position {pos_m} m outside lane {edge_id}_{index} (0..{length:.1f} m)"
            )
        return _Resolved(edge_id, index, pos_m)

    def _initial_state(self, start: _Resolved) -> np.ndarray:
        """Centre pose of the ego's start: front bumper at pos_m, shifted sideways by lateral_offset_m."""
        x_front, y_front, phi = self.road.pose_on_lane(f"{start.edge_id}_{start.lane_index}", start.pos_m)
        ego_length = self._type_length(self.config.ego_type_id)
        offset = self.config.ego.lateral_offset_m
        x = x_front - 0.5 * ego_length * math.cos(phi) - offset * math.sin(phi)
        y = y_front - 0.5 * ego_length * math.sin(phi) + offset * math.cos(phi)
        if not self.road.contains(x, y):
            raise CoSimulationError(
                f"ego start is off the road: centre ({x:.2f}, {y:.2f}) with lateral offset {offset} m is outside"
                f" the carriageway ({self.road.width_m:.2f} m wide)"
            )
        return np.array([x, y, phi, self.config.ego.speed_mps])

    def _type_length(self, type_id: str) -> float:
        """A vType's length from the route files (before SUMO runs; SUMO's default is 5 m)."""
        for route_file in self.config.route_files:
            try:
                root = ElementTree.parse(route_file).getroot()
            except ElementTree.ParseError as error:
                raise CoSimulationError(f"malformed route file {route_file}: {error}") from error
            for element in root.iter("vType"):
                if element.get("id") == type_id:
                    return float(element.get("length", 5.0))
        raise CoSimulationError(
            f"vType {type_id!r} is not defined in the route files {[str(r) for r in self.config.route_files]}"
        )

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
            self._bridge = SumoBridge(
                c.net_file, c.route_files, seed=c.seed, step_length_s=self.params.dt_s,
                lateral_resolution_m=c.lateral_resolution_m if c.sublane else None,
                log_file=c.sumo_log_file, quiet=c.quiet, keep_route=c.keep_route,
            )
        except SumoError as error:
            raise CoSimulationError(str(error)) from error
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
                for _ in range(round(c.warmup_s / self.params.dt_s)):
                    self._bridge.step()
            start = self._ego_start
            self._bridge.add_external_vehicle(
                c.ego_id, self._route_from(start.edge_id), c.ego_type_id, lane_index=start.lane_index,
                pos_m=start.pos_m, speed_mps=c.ego.speed_mps, wait=False,
            )
            if c.warmup_s == 0.0:
                self._add_spawns()
            self._bridge.wait_until_inserted(c.ego_id)
            self._bridge.subscribe_around(c.ego_id, c.sensing_range_m)
            # Put the ego exactly at our initial state (lateral offset included) before the first control step.
            self._bridge.move_external(c.ego_id, *self.state[:3], speed_mps=float(self.state[3]))
            self._bridge.step()
            present = set(self._bridge.vehicle_ids())
            missing = [o.id for o in c.obstacles if o.id not in present]
            if missing:
                raise SumoError(f"SUMO did not insert the obstacles {missing} (their spot is occupied?)")
            waiting = [v.id for v in c.vehicles if v.depart_s is None and v.id not in present]
            if waiting:  # SUMO inserts them when their spot is free (its insertion rules), not now
                warnings.warn(f"SUMO has not inserted {waiting} yet: no safe room at their start positions",
                              stacklevel=3)
        except (SumoError, CoSimulationError) as error:
            self.close()
            raise CoSimulationError(f"co-simulation set-up failed: {error}") from error
        except BaseException:
            self.close()
            raise

    def _add_spawns(self) -> None:
        for spawn in self.config.vehicles:
            r = self._resolve(spawn.edge_id, spawn.lane, spawn.pos_m, spawn.id)
            self._bridge.add_vehicle(
                spawn.id, self._route_from(r.edge_id), spawn.type_id, lane_index=r.lane_index, pos_m=r.pos_m,
                speed_mps=spawn.speed_mps, depart_s=spawn.depart_s,
            )
            self._bridge.configure_vehicle(
                spawn.id, max_speed_mps=spawn.max_speed_mps, speed_factor=spawn.speed_factor,
                imperfection=spawn.imperfection, lane_change_mode=None if spawn.lane_changes else 0,
            )

    def default_specification(self) -> Specification:
        """J1 on the ego's start lane at ``v_ref_mps``, plus J2 on the obstacles marked ``in_j2``."""
        index = self._ego_start.lane_index
        primitives: list[Any] = [
            PathTracking(
                path=self.road.lane_paths[index], lane=self.road.lane_role(index), v_ref_mps=self.config.v_ref_mps
            )
        ]
        circles = self.obstacle_circles(only_in_j2=True)
        if circles:
            primitives.append(ObstacleAvoidance(obstacles=circles))
        return Specification.of(*primitives)

    def obstacle_circles(self, only_in_j2: bool = False) -> tuple:
        """J2 circles covering the configured obstacles (as SUMO placed them)."""
        wanted = {o.id for o in self.config.obstacles if o.in_j2 or not only_in_j2}
        assert self.observation is not None
        return tuple(
            circle
            for obstacle in self.observation.obstacles
            if obstacle.id in wanted
            for circle in obstacle_circles(obstacle, self.ego_length_m, self.ego_width_m)
        )

    def _tracked_lane(self, specification: Specification) -> int | None:
        """The road lane whose path the attached J1 tracks (None if none or another path)."""
        tracking = specification.get("path_tracking")
        if not isinstance(tracking, PathTracking):
            return None
        cached = self._lane_of_path.get(id(tracking.path))
        if cached is None or cached[0] is not tracking.path:  # ids are reused after garbage collection
            lane = next(
                (i for i, path in enumerate(self.road.lane_paths) if path is tracking.path or path == tracking.path),
                None,
            )
            cached = self._lane_of_path[id(tracking.path)] = (tracking.path, lane)
        return cached[1]

    def _obstacle_state(self, obstacle_id: str) -> VehicleState | None:
        state = self._obstacle_states.get(obstacle_id)
        if state is None and self._bridge is not None and self._bridge.has_vehicle(obstacle_id):
            state = self._bridge.vehicle_state(obstacle_id)
            self._obstacle_states[obstacle_id] = state  # obstacles stand still: read once
        return state

    # --- running -------------------------------------------------------------------------------------
    @property
    def bridge(self) -> SumoBridge:
        """The SUMO bridge (for scenario scripts and tests that need more than the observation)."""
        if self._bridge is None:
            raise CoSimulationError("the co-simulation is closed")
        return self._bridge

    @property
    def time_s(self) -> float:
        return self.observation.time_s if self.observation is not None else float("nan")

    @property
    def running(self) -> bool:
        return self._bridge is not None and self._bridge.running

    def _observe(self) -> Observation:
        bridge = self.bridge
        ego, others = bridge.around()
        if ego is None:
            raise SumoError(
                f"the ego {self.config.ego_id!r} is no longer in SUMO at t={bridge.time_s:.2f} s"
                " (it left its route's end or the network)"
            )
        return self._observer.build(bridge.time_s, ego, others, bridge.emergency_vehicles(), bridge.collisions)

    def step(self) -> StepRecord:
        """One co-simulation step (see the module docstring). On failure SUMO is closed and records are kept."""
        if not self.running:
            raise CoSimulationError("the co-simulation is closed" + (f" after: {self.error}" if self.error else ""))
        started = time.perf_counter()
        try:
            observation = self.observation
            assert observation is not None
            state = self.state
            specification, version = self.slot.snapshot()
            surroundings = self._surroundings.build(observation, state, self._tracked_lane(specification))
            out = self.controller.step(state, specification, surroundings)
            new_state = vehicle.step(state, out.delta, out.throttle, out.brake, self.params)
            self._bridge.move_external(
                self.config.ego_id, float(new_state[0]), float(new_state[1]), float(new_state[2]),
                speed_mps=float(new_state[3]), accel_mps2=float(new_state[3] - state[3]) / self.params.dt_s,
            )
            self._bridge.step()
            self.observation = self._observe()
        except Exception as error:
            self.error = error
            self.close()
            raise CoSimulationError(
                f"co-simulation failed at t={self.time_s:.2f} s after {len(self.records)} recorded steps: {error}"
            ) from error
        ego = observation.ego
        ego_collisions = [c for c in observation.collisions if c.involves_ego]
        record = StepRecord(
            observation.time_s, *(float(v) for v in state), out.delta, out.throttle, out.brake,
            ego.x_m, ego.y_m, ego.heading_rad, ego.speed_mps, ego.lane_id, ego.lane_index, ego.lane_role,
            ego.road_s_m, ego.lateral_offset_m, version, specification.summary(), out.cost_min,
            out.effective_samples, out.solve_ms, (time.perf_counter() - started) * 1e3,
            len(observation.traffic), len(surroundings.moving_discs), len(ego_collisions),
        )
        self.records.append(record)
        self.collisions.extend(self.observation.collisions)
        self.state = new_state
        return record

    @property
    def reached_goal(self) -> bool:
        return self.observation is not None and self.observation.ego.road_s_m >= self.goal_s_m

    def run(
        self,
        duration_s: float | None = None,
        *,
        stop_at_goal: bool = True,
        on_step: Callable[[CoSimulation, StepRecord], bool | None] | None = None,
    ) -> RunSummary:
        """Step until the goal (or ``duration_s`` of simulated time, whichever first).

        ``on_step(cosim, record)`` runs after every step; returning True stops the run (scenario scripts
        change the specification from there, as the agent would from its thread).
        """
        if duration_s is None and not stop_at_goal:
            raise ValueError("give a duration or stop at the goal, or the run never ends")
        end = math.inf if duration_s is None else self.time_s + duration_s - 1e-9
        while self.time_s < end and not (stop_at_goal and self.reached_goal):
            record = self.step()
            if on_step is not None and on_step(self, record):
                break
        return self.summary()

    def summary(self) -> RunSummary:
        return RunSummary(
            steps=len(self.records),
            time_s=self.time_s,
            reached_goal=self.reached_goal,
            ego_collisions=sum(1 for c in self.collisions if c.involves_ego),
            collisions=len(self.collisions),
            max_position_error_m=max((r.position_error_m for r in self.records), default=0.0),
        )

    def to_dataframe(self):
        """The records as a pandas DataFrame (one row per step)."""
        import pandas as pd

        return pd.DataFrame([asdict(r) for r in self.records])

    # --- closing -------------------------------------------------------------------------------------
    def close(self) -> None:
        """Close SUMO (idempotent). Records, collisions and the last observation stay available."""
        if self._bridge is not None:
            self._bridge.close()

    def __enter__(self) -> CoSimulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
