"""The paper's vehicle model against steps computed by hand with its identified parameters."""

import math

import numpy as np
import pytest

from agentic_mpc.vehicle import (
    PAPER_PARAMS,
    VehicleParams,
    slip_angle,
    split_throttle_brake,
    step,
    step_plant,
    throttle_for_steady_speed,
)


def hand_step(x, y, phi, v, delta, a, b):
    r_delta, l_r, l_f = 0.1306, 8.184, -4.114
    w_a, w_b, w_v, dt = 4.615, -5.980, -0.07220, 0.04
    gamma = math.atan(l_r / (l_f + l_r) * math.tan(r_delta * delta))
    return (
        x + dt * v * math.cos(phi + gamma),
        y + dt * v * math.sin(phi + gamma),
        phi + dt * v / l_r * math.sin(gamma),
        max(0.0, v + dt * (w_a * a + w_b * b + w_v * v)),
    )


@pytest.mark.parametrize(
    "state, inputs",
    [
        ((0.0, 0.0, 0.0, 15.0), (0.0, 0.2347, 0.0)),
        ((10.0, -3.0, 0.3, 12.0), (0.5, 0.6, 0.0)),
        ((5.0, 2.0, -1.2, 20.0), (-1.0, 0.0, 0.8)),
        ((0.0, 0.0, 3.0, 0.1), (0.7, 0.0, 1.0)),  # brakes to a stop: speed clamps at zero
    ],
)
def test_one_step_matches_hand_computation(state, inputs):
    assert np.allclose(step(state, *inputs), hand_step(*state, *inputs), rtol=0, atol=1e-12)


def test_hand_numbers_for_a_left_turn():
    # delta = 1: gamma = atan(8.184 / 4.07 * tan(0.1306)) = 0.258219 rad
    gamma = float(slip_angle(1.0))
    assert gamma == pytest.approx(0.258219, abs=1e-6)
    x, y, phi, v = step([0.0, 0.0, 0.0, 10.0], 1.0, 0.0, 0.0)
    assert x == pytest.approx(0.4 * math.cos(gamma), abs=1e-12)
    assert y > 0 and phi > 0  # positive steering turns left
    assert phi == pytest.approx(0.04 * 10.0 / 8.184 * math.sin(gamma), abs=1e-12)
    assert v == pytest.approx(10.0 - 0.04 * 0.0722 * 10.0, abs=1e-12)


def test_steering_saturates_at_the_actuator_limit():
    assert np.allclose(step([0, 0, 0, 10.0], 3.0, 0, 0), step([0, 0, 0, 10.0], 1.0, 0, 0))


def test_vectorised_over_samples():
    states = np.array([[0.0, 1.0], [0.0, 2.0], [0.0, 0.1], [10.0, 5.0]])
    batch = step(states, np.array([0.2, -0.4]), np.array([0.5, 0.0]), np.array([0.0, 0.3]))
    for s in range(2):
        assert np.allclose(batch[:, s], hand_step(*states[:, s], [0.2, -0.4][s], [0.5, 0.0][s], [0.0, 0.3][s]))


def test_throttle_brake_split_and_steady_speed():
    throttle, brake = split_throttle_brake([-1.5, -0.3, 0.0, 0.4, 2.0])
    assert throttle.tolist() == [0.0, 0.0, 0.0, 0.4, 1.0]
    assert brake.tolist() == [1.0, 0.3, 0.0, 0.0, 0.0]
    a = throttle_for_steady_speed(15.0)
    assert a == pytest.approx(0.0722 * 15 / 4.615)
    assert step([0, 0, 0, 15.0], 0.0, a, 0.0)[3] == pytest.approx(15.0)
    assert PAPER_PARAMS.max_speed_mps == pytest.approx(63.92, abs=0.01)


def test_invalid_parameters_are_named():
    with pytest.raises(ValueError, match="dt_s"):
        VehicleParams(dt_s=0.0)
    with pytest.raises(ValueError, match="w_a"):
        VehicleParams(w_a=float("nan"))


def test_the_plants_scalar_step_equals_the_numpy_model():
    rng = np.random.default_rng(8)
    for _ in range(500):
        state = rng.uniform([-1e3, -1e3, -7.0, 0.0], [1e3, 1e3, 7.0, 40.0])
        delta, ab = rng.uniform(-1.5, 1.5, size=2)  # beyond the actuator limits too
        throttle, brake = max(ab, 0.0), max(-ab, 0.0) * 1.3
        expected = step(state, delta, throttle, brake)
        np.testing.assert_allclose(step_plant(state, delta, throttle, brake), expected, rtol=1e-14, atol=1e-12)
    assert step_plant(np.array([0.0, 0.0, 0.0, 0.1]), 0.0, 0.0, 1.0)[3] == 0.0  # never backwards
