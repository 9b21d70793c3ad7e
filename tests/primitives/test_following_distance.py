"""J4, following distance: its cost is the along-path error to the wanted gap behind the nearest leader."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import FollowingDistance, Leader, Rollouts, Specification, StepContext, Surroundings
from agentic_mpc.vehicle import PAPER_PARAMS

H = 20
DT = PAPER_PARAMS.dt_s


def leader_at(gap_m: float, speed_mps: float, y_m: float = 0.0) -> Leader:
    """A leader straight ahead on y = y_m: the ego's centre would touch it at x = gap + v t (ego at x = 0)."""
    t = DT * np.arange(1, H + 1)
    return Leader(np.column_stack([gap_m + speed_mps * t, np.full(H, y_m)]), np.tile([1.0, 0.0], (H, 1)))


def context(leaders, state=(0.0, 0.0, 0.0, 20.0)) -> StepContext:
    return StepContext(np.array(state), H, PAPER_PARAMS, Surroundings(leaders=tuple(leaders)))


def rollouts(x: np.ndarray, y: np.ndarray) -> Rollouts:
    zeros = np.zeros_like(x)
    return Rollouts(x_m=x, y_m=y, phi_rad=zeros, v_mps=zeros, delta=zeros, throttle=zeros, brake=zeros,
                    delta_command=zeros, ab_command=zeros)


def test_cost_is_the_along_path_error_to_the_wanted_gap_moving_at_the_approach_rate():
    j4 = FollowingDistance(gap_m=20.0, weight=4.0, approach_mps=2.0)
    leader = leader_at(30.0, 18.0)
    prepared = j4.prepare(context([leader]))
    t = DT * np.arange(1, H + 1)
    gap_now = leader.contact_points[0, 0]  # the gap at the first stage, as J0's time gap starts from
    wanted = gap_now + np.clip(20.0 - gap_now, -2.0 * t, 2.0 * t)  # from there towards 20 m at 2 m/s
    target_x = leader.contact_points[:, 0] - wanted
    x = np.column_stack([20.0 * t, 20.0 * t + 1.0])  # two plans: at 20 m/s, and 1 m further on
    y = np.column_stack([np.zeros(H), np.full(H, 3.0)])  # the second also 3 m aside: not counted
    cost = prepared.cost(rollouts(x, y))
    expected = 0.5 * 4.0 / H * ((x - target_x[:, None]) ** 2).sum(axis=0)
    np.testing.assert_allclose(cost, expected, rtol=1e-12)


def test_the_nearest_leader_counts_and_no_leader_costs_nothing():
    j4 = FollowingDistance(gap_m=10.0)
    near, far = leader_at(12.0, 15.0), leader_at(40.0, 15.0)
    x = np.tile(20.0 * DT * np.arange(1, H + 1)[:, None], (1, 3))
    y = np.zeros_like(x)
    both = j4.prepare(context([far, near])).cost(rollouts(x, y))
    only_near = j4.prepare(context([near])).cost(rollouts(x, y))
    np.testing.assert_array_equal(both, only_near)
    assert np.all(j4.prepare(context([])).cost(rollouts(x, y)) == 0.0)


def test_parameters_are_validated():
    with pytest.raises(ValueError):
        FollowingDistance(gap_m=1.0)
    with pytest.raises(ValueError):
        FollowingDistance(gap_m=20.0, weight=0.0)


def test_the_controller_closes_a_long_gap_and_opens_a_short_one():
    """Closed loop against a leader at 20 m/s: J4 moves the ego's speed the way the gap needs."""
    def speed_after(gap_now_m: float, wanted_m: float) -> float:
        controller = FourierMPPI(MPPIConfig(), seed=3)
        state = np.array([0.0, 0.0, 0.0, 20.0])
        spec = Specification.of(FollowingDistance(gap_m=wanted_m))
        horizon = controller.config.horizon
        t = DT * np.arange(1, horizon + 1)
        leader = Leader(np.column_stack([gap_now_m + 20.0 * t, np.zeros(horizon)]), np.tile([1.0, 0.0], (horizon, 1)))
        from agentic_mpc.vehicle import step
        for _ in range(50):
            out = controller.step(state, spec, Surroundings(leaders=(leader,)))
            state = step(state, out.delta, out.throttle, out.brake)
        return float(state[3])

    assert speed_after(60.0, 30.0) > 20.5  # too far back: faster than the leader
    assert speed_after(30.0, 60.0) < 19.5  # too close: slower
