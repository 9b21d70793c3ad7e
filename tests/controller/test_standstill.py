"""A standing car asked to move moves: the pinned first input is freed at standstill."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import PathTracking, Specification
from agentic_mpc.vehicle import step_plant

PATH = [(0.0, 0.0), (300.0, 0.0)]


def _drive(config: MPPIConfig, v_ref_mps: float, steps: int = 150) -> np.ndarray:
    """Start standing with the warm start braking at 0.15 (where a stop leaves it), and drive ``steps``."""
    controller = FourierMPPI(config, seed=3)
    mean = np.zeros((2, config.coefficients))
    mean[1, 0] = -0.15
    controller.reset(mean)
    controller.previous_input = (0.0, -0.15)
    spec = Specification.of(PathTracking(path=PATH, v_ref_mps=v_ref_mps))
    state = np.array([0.0, 0.0, 0.0, 0.0])
    for _ in range(steps):
        out = controller.step(state, spec)
        state = step_plant(state, out.delta, out.throttle, out.brake)
    return state


def _first_input(config: MPPIConfig, v_mps: float, v_ref_mps: float) -> float:
    controller = FourierMPPI(config, seed=3)
    mean = np.zeros((2, config.coefficients))
    mean[1, 0] = -0.15
    controller.reset(mean)
    controller.previous_input = (0.0, -0.15)
    out = controller.step(np.array([0.0, 0.0, 0.0, v_mps]), Specification.of(PathTracking(path=PATH, v_ref_mps=v_ref_mps)))
    return out.throttle - out.brake


def test_u0_is_sampled_only_when_standing_and_asked_to_move():
    """Pinned, the applied input is the warm start's (-0.15) whatever the costs: braking at 0 m/s changes no
    rollout, so nothing would ever let go of it (docs/traffic.md)."""
    assert _first_input(MPPIConfig(free_start_below_mps=None), 0.0, 15.0) == pytest.approx(-0.15, abs=1e-12)
    assert _first_input(MPPIConfig(), 5.0, 15.0) == pytest.approx(-0.15, abs=1e-12)  # moving: pinned
    assert _first_input(MPPIConfig(), 0.0, 0.0) == pytest.approx(-0.15, abs=1e-12)  # asked to stand: pinned
    assert _first_input(MPPIConfig(), 0.0, 15.0) > 0.0  # standing, asked to go: it lets go of the brake


def test_a_standing_car_asked_to_move_pulls_away():
    state = _drive(MPPIConfig(), v_ref_mps=15.0)
    assert state[3] > 5.0 and state[0] > 10.0


def test_a_car_asked_to_stand_stays_standing():
    state = _drive(MPPIConfig(), v_ref_mps=0.0)
    assert state[0] == pytest.approx(0.0, abs=1e-9)
