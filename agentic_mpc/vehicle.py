"""The ego vehicle: the paper's kinematic bicycle model with linear speed dynamics.

State ``[x_m, y_m, phi_rad, v_mps]`` (x forward/east, y left/north, heading counter-clockwise from +x),
input ``[delta, throttle, brake]`` with ``delta`` the normalised steering command (positive turns LEFT),
``throttle`` and ``brake`` in [0, 1]. ``(x, y)`` is the reference point the model's slip angle is defined at
(the vehicle's centre); the SUMO bridge converts it to SUMO's front bumper.

This module is the readable NumPy form of the dynamics, written exactly as printed in the paper. It is
vectorised over trailing axes so the MPPI reference path can roll out all samples at once; the fast path
(``controller/kernels.py``) reproduces it without transcendental calls and is tested against it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

DT_S = 0.04
"""The paper's sampling interval."""

STEER_LIMIT = 1.0
"""Actuator limit of the normalised steering command |delta| (CARLA's convention, as in the paper)."""


@dataclass(frozen=True, slots=True)
class VehicleParams:
    """Identified parameters of the paper's vehicle model (section "Vehicle Dynamics")."""

    r_delta: float = 0.1306
    """Steering command to road-wheel angle gain, rad per unit command."""
    l_r_m: float = 8.184
    """Identified distance from the reference point to the rear axle."""
    l_f_m: float = -4.114
    """Identified distance from the reference point to the front axle (negative as identified)."""
    w_a: float = 4.615
    """Throttle gain, m/s^2 per unit throttle."""
    w_b: float = -5.980
    """Brake gain, m/s^2 per unit brake."""
    w_v: float = -0.07220
    """Speed damping, 1/s."""
    dt_s: float = DT_S

    def __post_init__(self) -> None:
        for name in ("r_delta", "l_r_m", "l_f_m", "w_a", "w_b", "w_v", "dt_s"):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise ValueError(f"VehicleParams.{name} must be finite, got {value!r}")
        if self.dt_s <= 0:
            raise ValueError(f"VehicleParams.dt_s must be positive, got {self.dt_s!r}")
        if self.l_r_m <= 0 or self.l_f_m + self.l_r_m <= 0:
            raise ValueError("VehicleParams needs l_r_m > 0 and a positive wheelbase l_f_m + l_r_m")

    @property
    def slip_gain(self) -> float:
        """l_r / (l_f + l_r): tan(gamma) = slip_gain * tan(r_delta * delta)."""
        return self.l_r_m / (self.l_f_m + self.l_r_m)

    @property
    def max_speed_mps(self) -> float:
        """Steady-state speed at full throttle (w_a + w_v v = 0)."""
        return -self.w_a / self.w_v


    def pull_out_turn(self, steer: float = 1.0) -> tuple[float, float, float]:
        """(radius of the path, cos gamma, sin gamma) when steering at ``steer`` (a share of full lock): the
        motion runs at the slip angle gamma to the heading at once, then turns on a circle of radius
        l_r / sin(gamma)."""
        gamma = math.atan(self.slip_gain * math.tan(self.r_delta * min(max(steer, 0.0), STEER_LIMIT)))
        return (self.l_r_m / math.sin(gamma) if gamma > 0.0 else math.inf), math.cos(gamma), math.sin(gamma)

    def pull_out_distance_m(self, lateral_m: float, steer: float = 1.0) -> float:
        """How far ahead the reference point has moved when it is ``lateral_m`` to the side, starting straight
        and steering at ``steer`` throughout (:meth:`pull_out_turn`). Inf if it never gets there."""
        radius, cos_gamma, sin_gamma = self.pull_out_turn(steer)
        if not math.isfinite(radius):
            return math.inf
        cos_end = cos_gamma - lateral_m / radius
        if cos_end < 0.0:  # the circle turns back before it gets that far aside
            return math.inf
        return radius * (math.sqrt(1.0 - cos_end * cos_end) - sin_gamma)


PAPER_PARAMS = VehicleParams()

URBAN_PARAMS = VehicleParams(r_delta=0.6, l_r_m=1.54, l_f_m=1.54)
"""The same car for streets with junctions: the paper's identification (highway driving, steering within 7.5
degrees of road-wheel angle) turns no tighter than a 32 m radius (l_r / sin(gamma) at full lock), too wide for any
junction. This one is a kinematic bicycle about the car's centre (the Nissan Patrol's 3.08 m wheelbase halved)
with 34 degrees of road-wheel angle at full lock (4.8 m radius), and the paper's identified speed dynamics."""

VEHICLE_MODELS = {"paper": PAPER_PARAMS, "urban": URBAN_PARAMS}
"""The plant by the name a scenario gives it (``simulation: {vehicle_model: ...}``)."""


def split_throttle_brake(ab: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One throttle/brake series to (throttle, brake): a = Sat[0,1](ab), b = -Sat[-1,0](ab)."""
    ab = np.asarray(ab, dtype=np.float64)
    return np.clip(ab, 0.0, 1.0), -np.clip(ab, -1.0, 0.0)


def slip_angle(delta: ArrayLike, params: VehicleParams = PAPER_PARAMS) -> NDArray[np.float64]:
    """gamma = arctan(l_r / (l_f + l_r) * tan(r_delta * delta)), with delta saturated at the actuator limit."""
    delta = np.clip(np.asarray(delta, dtype=np.float64), -STEER_LIMIT, STEER_LIMIT)
    return np.arctan(params.slip_gain * np.tan(params.r_delta * delta))


def step(
    state: ArrayLike,
    delta: ArrayLike,
    throttle: ArrayLike,
    brake: ArrayLike,
    params: VehicleParams = PAPER_PARAMS,
) -> NDArray[np.float64]:
    """One step of the paper's model. ``state`` has shape (4, ...); inputs broadcast against ``state[0]``.

    Throttle and brake are clipped to [0, 1] and steering to [-1, 1]: these are actuator limits, so the
    plant and every predicted rollout see the same saturation.
    """
    x, y, phi, v = np.asarray(state, dtype=np.float64)
    gamma = slip_angle(delta, params)
    throttle = np.clip(np.asarray(throttle, dtype=np.float64), 0.0, 1.0)
    brake = np.clip(np.asarray(brake, dtype=np.float64), 0.0, 1.0)
    dt = params.dt_s
    return np.stack(
        [
            x + dt * v * np.cos(phi + gamma),
            y + dt * v * np.sin(phi + gamma),
            phi + dt * v / params.l_r_m * np.sin(gamma),
            np.maximum(0.0, v + dt * (params.w_a * throttle + params.w_b * brake + params.w_v * v)),
        ]
    )


def step_plant(
    state: NDArray[np.float64], delta: float, throttle: float, brake: float, params: VehicleParams = PAPER_PARAMS
) -> NDArray[np.float64]:
    """:func:`step` for one vehicle, in scalar arithmetic: what the worlds call every 40 ms on the ego.

    The same formulas in the same order; on 0-d arrays NumPy spends about 0.1 ms per step on the project
    machine in call overhead, this about 5 us (tests/test_vehicle.py compares the two).
    """
    x, y, phi, v = state.tolist() if isinstance(state, np.ndarray) else (float(value) for value in state)
    delta = min(max(float(delta), -STEER_LIMIT), STEER_LIMIT)
    gamma = math.atan(params.slip_gain * math.tan(params.r_delta * delta))
    throttle = min(max(float(throttle), 0.0), 1.0)
    brake = min(max(float(brake), 0.0), 1.0)
    dt = params.dt_s
    return np.array([
        x + dt * v * math.cos(phi + gamma),
        y + dt * v * math.sin(phi + gamma),
        phi + dt * v / params.l_r_m * math.sin(gamma),
        max(0.0, v + dt * (params.w_a * throttle + params.w_b * brake + params.w_v * v)),
    ])


def throttle_for_steady_speed(v_mps: float, params: VehicleParams = PAPER_PARAMS) -> float:
    """The throttle that holds ``v_mps`` on a flat road (useful to warm-start a controller)."""
    return float(np.clip(-params.w_v * v_mps / params.w_a, 0.0, 1.0))
