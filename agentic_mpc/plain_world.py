"""A plain-Python world around the controller: a straight 3-lane road, scripted traffic, obstacles, no SUMO.

It exists so that the agent and the MCP server can be run and tested end to end without a simulator
(``agentic-mpc serve`` uses it until the SUMO co-simulation is plugged in through the same two callables):

- ``latest_observation() -> dict`` with the top-level keys ``time_s``, ``ego``, ``traffic``,
  ``emergency_vehicles``, ``obstacles``, ``collisions`` (the shape of the SUMO bridge's ``Observation``);
- ``road_lanes() -> RoadLanes``, the lane source of :mod:`agentic_mpc.tools`.

The ego is the paper's vehicle model driven by :class:`~agentic_mpc.controller.FourierMPPI`; the other road
users drive along their lane at a desired speed and slow down behind whoever is ahead in their lane (so an
ambulance waits behind the ego until the ego makes way). Each control step: apply the agent's due changes,
read one specification snapshot, solve, move everyone, publish the observation.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import (
    Circle,
    MovingDisc,
    ObstacleAvoidance,
    PathTracking,
    Specification,
    SpecificationSlot,
    Surroundings,
    TrackingReference,
)
from agentic_mpc.tools import ControllerTools, RoadLanes
from agentic_mpc.vehicle import step as vehicle_step

logger = logging.getLogger(__name__)

EGO_RADIUS_M = 1.5
"""Radius of the disc standing for the ego in collision checks."""


@dataclass(frozen=True)
class StraightRoad:
    """Three lanes along +x, 3.5 m apart: "center" on y = 0, "left" at +w, "right" at -w."""

    lane_width_m: float = 3.5
    start_x_m: float = -100.0
    length_m: float = 20_000.0
    speed_limit_mps: float = 25.0

    def __post_init__(self) -> None:
        if not (self.lane_width_m > 0 and self.length_m > 0 and self.speed_limit_mps > 0):
            raise ValueError("StraightRoad needs a positive lane width, length and speed limit")

    def lane_y_m(self, label: str) -> float:
        return {"center": 0.0, "left": self.lane_width_m, "right": -self.lane_width_m}[label]

    def lanes(self) -> dict[str, LanePath]:
        end = self.start_x_m + self.length_m
        return {
            label: LanePath.straight((self.start_x_m, y), (end, y), name=label)
            for label, y in ((lab, self.lane_y_m(lab)) for lab in ("center", "left", "right"))
        }

    def lane_of(self, y_m: float) -> str:
        return min(("center", "left", "right"), key=lambda label: abs(y_m - self.lane_y_m(label)))

    @property
    def left_edge_y_m(self) -> float:
        return 1.5 * self.lane_width_m

    @property
    def right_edge_y_m(self) -> float:
        return -1.5 * self.lane_width_m


def paper_initial_specification(
    lanes: dict[str, LanePath], v_ref_mps: float = 15.0, obstacles: Sequence[Circle] = ()
) -> Specification:
    """The paper's initial specification: J1 on the center lane at 15 m/s, plus J2 when there are obstacles."""
    tracking = PathTracking(path=lanes["center"], lane="center", v_ref_mps=v_ref_mps)
    if obstacles:
        return Specification.of(tracking, ObstacleAvoidance(obstacles=tuple(obstacles)))
    return Specification.of(tracking)


@dataclass
class ScriptedVehicle:
    """Another road user: drives along ``lane`` at ``desired_speed_mps`` from ``appear_at_s`` on.

    ``x_m=None`` places it ``behind_ego_m`` behind the ego when it appears (an ambulance coming up behind).
    """

    id: str
    lane: str
    x_m: float | None
    desired_speed_mps: float
    type: str = "passenger"
    emergency: bool = False
    radius_m: float = 2.0
    appear_at_s: float = 0.0
    behind_ego_m: float = 120.0
    speed_mps: float | None = None

    def __post_init__(self) -> None:
        if self.speed_mps is None:
            self.speed_mps = self.desired_speed_mps


@dataclass
class PlainWorldConfig:
    road: StraightRoad = field(default_factory=StraightRoad)
    ego_x_m: float = 0.0
    ego_lane: str = "center"
    ego_speed_mps: float = 15.0
    vehicles: list[ScriptedVehicle] = field(default_factory=list)
    obstacles: list[Circle] = field(default_factory=list)
    mppi: MPPIConfig = field(default_factory=MPPIConfig)
    seed: int = 0


def demo_config(ambulance_at_s: float | None = 30.0) -> PlainWorldConfig:
    """What ``agentic-mpc serve`` drives by default: an obstacle on the centre lane, a slower car on the right
    lane, and (optionally) an ambulance that comes up behind the ego in the centre lane."""
    vehicles = [ScriptedVehicle("car0", "right", 60.0, 11.0)]
    if ambulance_at_s is not None:
        vehicles.append(
            ScriptedVehicle(
                "ambulance0", "center", None, 22.0, type="ambulance", emergency=True, appear_at_s=ambulance_at_s
            )
        )
    return PlainWorldConfig(vehicles=vehicles, obstacles=[Circle(x_m=80.0, y_m=0.0, radius_m=2.0, label="obstacle0")])


@dataclass
class StepTiming:
    """Wall-clock timing of one control step."""

    time_s: float
    compute_ms: float
    """Specification snapshot + surroundings + MPPI solve + moving everyone."""
    late_ms: float
    """How much later than its tick the step started (realtime pacing only)."""


class PlainWorld:
    """The closed loop. ``step()`` advances one control step; ``start()`` runs steps in a background thread."""

    def __init__(
        self,
        config: PlainWorldConfig | None = None,
        slot: SpecificationSlot | None = None,
        tools: ControllerTools | None = None,
    ) -> None:
        self.config = config or PlainWorldConfig()
        c = self.config
        self.road = c.road
        self._lanes = self.road.lanes()
        self.slot = slot or SpecificationSlot(paper_initial_specification(self._lanes, obstacles=c.obstacles))
        self.tools = tools or ControllerTools(self.slot, self.road_lanes)
        self.controller = FourierMPPI(c.mppi, seed=c.seed)
        self.dt_s = self.controller.params.dt_s
        self.state = np.array([c.ego_x_m, self.road.lane_y_m(c.ego_lane), 0.0, c.ego_speed_mps])
        self.vehicles = [ScriptedVehicle(**vars(v)) for v in c.vehicles]  # own copies: they move
        self._appeared: set[str] = set()
        self._appear(0.0)
        self.step_index = 0
        self.timings: list[StepTiming] = []
        self.on_step: list[Callable[[dict[str, Any]], None]] = []
        """Called after every step with the new observation (from the loop's thread; keep them quick)."""
        self._observation = self._observe([])
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    # ------------------------------------------------------------------ the two callables
    def road_lanes(self) -> RoadLanes:
        return RoadLanes(self._lanes, self.road.speed_limit_mps)

    def latest_observation(self) -> dict[str, Any]:
        """The observation after the last step (a new dict each step; safe to read from any thread)."""
        return self._observation

    @property
    def time_s(self) -> float:
        return self.step_index * self.dt_s

    # ------------------------------------------------------------------ one control step
    def step(self) -> dict[str, Any]:
        t = self.time_s
        self.tools.apply_due(t)
        specification = self.slot.current  # one snapshot per step
        output = self.controller.step(self.state, specification, self._surroundings())
        self.state = vehicle_step(self.state, output.delta, output.throttle, output.brake, self.controller.params)
        self._move_traffic(t)
        self.step_index += 1
        self._observation = self._observe(self._collisions())
        for listener in list(self.on_step):
            try:
                listener(self._observation)
            except Exception:  # a broken listener must not stop the car
                logger.exception("an on_step listener raised; the loop continues")
        return self._observation

    def _active(self) -> list[ScriptedVehicle]:
        return [v for v in self.vehicles if v.id in self._appeared]

    def _appear(self, t: float) -> None:
        for v in self.vehicles:
            if v.id not in self._appeared and t >= v.appear_at_s:
                if v.x_m is None:
                    v.x_m = float(self.state[0]) - v.behind_ego_m
                self._appeared.add(v.id)

    def _surroundings(self) -> Surroundings:
        h = self.controller.config.horizon
        k = np.arange(1, h + 1)
        discs = tuple(
            MovingDisc(
                np.stack([v.x_m + v.speed_mps * self.dt_s * k, np.full(h, self.road.lane_y_m(v.lane))], axis=1),
                v.radius_m + EGO_RADIUS_M,
            )
            for v in self._active()
            if abs(v.x_m - self.state[0]) < 150.0
        )
        ahead = self.state[0] + max(self.state[3], 1.0) * self.dt_s * k
        tangents = np.tile([1.0, 0.0], (h, 1))

        def edge(y: float) -> TrackingReference:
            return TrackingReference(np.stack([ahead, np.full(h, y)], axis=1), tangents)

        return Surroundings(discs, edge(self.road.left_edge_y_m), edge(self.road.right_edge_y_m))

    def _move_traffic(self, t: float) -> None:
        self._appear(t)
        movers = self._active()
        for v in movers:
            y = self.road.lane_y_m(v.lane)
            # The nearest road user ahead in the same lane (the ego included), for a simple gap keeping.
            leaders = [(float(self.state[0]), float(self.state[3]))] if abs(self.state[1] - y) < 2.5 else []
            leaders += [(o.x_m, o.speed_mps) for o in movers if o is not v and o.lane == v.lane]
            leaders = [(x, s) for x, s in leaders if x > v.x_m]
            target = v.desired_speed_mps
            if leaders:
                x_lead, v_lead = min(leaders)
                gap = x_lead - v.x_m - 8.0
                if gap < 10.0 + 1.5 * v.speed_mps:
                    target = min(target, v_lead if gap > 2.0 else 0.0)
            rate = 2.0 if target > v.speed_mps else 6.0
            v.speed_mps += float(np.clip(target - v.speed_mps, -rate * self.dt_s, rate * self.dt_s))
            v.x_m += v.speed_mps * self.dt_s

    def _collisions(self) -> list[dict[str, Any]]:
        x, y = float(self.state[0]), float(self.state[1])
        hits = [
            {"time_s": self.time_s, "other": v.id, "distance_m": round(d, 3)}
            for v in self._active()
            if (d := math.hypot(v.x_m - x, self.road.lane_y_m(v.lane) - y)) < v.radius_m + EGO_RADIUS_M
        ]
        hits += [
            {"time_s": self.time_s, "other": o.label or f"obstacle{i}", "distance_m": round(d, 3)}
            for i, o in enumerate(self.config.obstacles)
            if (d := math.hypot(o.x_m - x, o.y_m - y)) < o.radius_m + EGO_RADIUS_M
        ]
        return hits

    def _observe(self, collisions: list[dict[str, Any]]) -> dict[str, Any]:
        x, y, phi, v = (float(s) for s in self.state)
        traffic = [
            {
                "id": o.id,
                "type": o.type,
                "vclass": "emergency" if o.emergency else "passenger",
                "emergency": o.emergency,
                "x_m": round(o.x_m, 3),
                "y_m": self.road.lane_y_m(o.lane),
                "heading_rad": 0.0,
                "speed_mps": round(o.speed_mps, 3),
                "lane": o.lane,
            }
            for o in self._active()
        ]
        return {
            "time_s": round(self.time_s, 6),
            "ego": {
                "id": "ego",
                "x_m": round(x, 3),
                "y_m": round(y, 3),
                "heading_rad": round(phi, 5),
                "speed_mps": round(v, 3),
                "lane": self.road.lane_of(y),
                "specification": self.slot.current.summary(),
            },
            "traffic": traffic,
            "emergency_vehicles": [o for o in traffic if o["emergency"]],
            "obstacles": [
                {"id": o.label or f"obstacle{i}", "x_m": o.x_m, "y_m": o.y_m, "radius_m": o.radius_m}
                for i, o in enumerate(self.config.obstacles)
            ],
            "collisions": collisions,
        }

    # ------------------------------------------------------------------ running
    def run(self, duration_s: float | None = None, realtime: bool = True, time_scale: float = 1.0) -> None:
        """Step until ``duration_s`` of sim time (forever if None) or :meth:`stop`.

        With ``realtime`` each step starts on its tick (dt * time_scale of wall time); a step that starts
        late is recorded in ``timings`` (``late_ms``), never skipped.
        """
        end_step = None if duration_s is None else self.step_index + round(duration_s / self.dt_s)
        tick_s = self.dt_s * time_scale
        start_wall, start_step = time.perf_counter(), self.step_index
        while not self._stop.is_set() and (end_step is None or self.step_index < end_step):
            due = start_wall + (self.step_index - start_step) * tick_s
            if realtime:
                wait = due - time.perf_counter()
                if wait > 0 and self._stop.wait(wait):
                    break
            started = time.perf_counter()
            t = self.time_s
            self.step()
            self.timings.append(
                StepTiming(
                    t, (time.perf_counter() - started) * 1e3, max(0.0, (started - due) * 1e3) if realtime else 0.0
                )
            )

    def start(
        self, duration_s: float | None = None, realtime: bool = True, time_scale: float = 1.0
    ) -> threading.Thread:
        """Run in a background (daemon) thread."""
        self._stop.clear()
        self._thread = threading.Thread(
            target=self.run, args=(duration_s, realtime, time_scale), name="plain-world", daemon=True
        )
        self._thread.start()
        return self._thread

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None
