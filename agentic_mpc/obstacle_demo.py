"""The paper's Scenario 1 without traffic: a circular obstacle on a straight lane, with and without J3.

``agentic-mpc demo`` runs it over several seeds for each variant, prints the table of pass sides and
recovery, and draws the bird's-eye plot (the paper's Figure 3) and speed/lateral offset over time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from agentic_mpc.closed_loop import Trajectory, run_closed_loop
from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import (
    Circle,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
    SpecificationSlot,
)
from agentic_mpc.vehicle import throttle_for_steady_speed

Variant = Literal["no_message", "message_right", "message_left"]
VARIANTS: tuple[Variant, ...] = ("no_message", "message_right", "message_left")


@dataclass(frozen=True)
class ObstacleScene:
    """A straight road along +x; the obstacle sits on the centre lane ``obstacle_ahead_m`` ahead of the start."""

    v_ref_mps: float = 15.0
    obstacle_ahead_m: float = 45.0
    obstacle_radius_m: float = 2.0
    lane_width_m: float = 3.5
    road_length_m: float = 400.0
    duration_s: float = 10.0

    @property
    def centre_lane(self) -> LanePath:
        return LanePath.straight((-20.0, 0.0), (self.road_length_m, 0.0), name="center")

    @property
    def left_lane(self) -> LanePath:
        return self.centre_lane.parallel(self.lane_width_m, name="left")

    @property
    def obstacle(self) -> Circle:
        return Circle(x_m=self.obstacle_ahead_m, y_m=0.0, radius_m=self.obstacle_radius_m, label="obstacle")

    def initial_specification(self) -> Specification:
        """The paper's initial attachment: J1 on the centre lane at v_ref, and J2."""
        return Specification.of(
            PathTracking(path=self.centre_lane, lane="center", v_ref_mps=self.v_ref_mps),
            ObstacleAvoidance(obstacles=(self.obstacle,)),
        )

    def initial_state(self) -> np.ndarray:
        return np.array([0.0, 0.0, 0.0, self.v_ref_mps])

    @property
    def steps(self) -> int:
        return round(self.duration_s / 0.04)


@dataclass(frozen=True)
class PassResult:
    """How one run went past the obstacle."""

    side: Literal["left", "right", "hit"]
    min_clearance_m: float
    """Smallest distance of the ego's centre from the obstacle's boundary (negative: it entered)."""
    recovery_s: float
    """Time after passing until the ego is back within 0.5 m of the lane and 1 m/s of v_ref and stays there
    for at least 1 s (both as 1 s moving averages: MPPI at S = 256 leaves a speed ripple of about 1 m/s)."""


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Centred moving average with the window shrinking at the ends."""
    if window <= 1:
        return values
    kernel = np.ones(window)
    return np.convolve(values, kernel, "same") / np.convolve(np.ones_like(values), kernel, "same")


def analyse_pass(trajectory: Trajectory, scene: ObstacleScene, lane_tolerance_m: float = 0.5,
                 speed_tolerance_mps: float = 1.0, smoothing_s: float = 1.0) -> PassResult:
    states = trajectory.state_array
    x, y, v = states[:, 0], states[:, 1], states[:, 3]
    obstacle = scene.obstacle
    distance = np.hypot(x - obstacle.x_m, y - obstacle.y_m) - obstacle.radius_m
    min_clearance = float(distance.min())
    passing = int(np.argmax(x >= obstacle.x_m)) if np.any(x >= obstacle.x_m) else len(x) - 1
    lateral = scene.centre_lane.lateral_offset(x, y)
    if min_clearance < 0.0:
        side: Literal["left", "right", "hit"] = "hit"
    else:
        side = "left" if lateral[passing] > 0 else "right"
    window = max(1, round(smoothing_s / trajectory.dt_s))
    settled = (np.abs(moving_average(lateral, window)) <= lane_tolerance_m) & (
        np.abs(moving_average(v, window) - scene.v_ref_mps) <= speed_tolerance_mps
    )
    hold = window  # back means back for at least the smoothing window, not a crossing
    after = settled[passing:]
    sustained = np.array([after[i : i + hold].all() and i + hold <= len(after) for i in range(len(after))])
    recovery = float(np.argmax(sustained)) * trajectory.dt_s if sustained.any() else float("inf")
    return PassResult(side, min_clearance, recovery)


def variant_changes(variant: Variant, at_step: int = 0) -> dict:
    """The specification change each variant's user message leads to (the agent's tool call)."""
    if variant == "no_message":
        return {}
    direction = "right" if variant == "message_right" else "left"
    return {at_step: lambda spec: spec.attach(PreferredSteeringDirection(direction=direction))}


def run_obstacle_variant(variant: Variant, seed: int, scene: ObstacleScene | None = None,
                         config: MPPIConfig | None = None) -> Trajectory:
    scene = scene or ObstacleScene()
    controller = FourierMPPI(config, seed=seed)
    controller.mean[1, 0] = throttle_for_steady_speed(scene.v_ref_mps)  # start cruising, not coasting
    slot = SpecificationSlot(scene.initial_specification())
    return run_closed_loop(controller, slot, scene.initial_state(), scene.steps, variant_changes(variant))
