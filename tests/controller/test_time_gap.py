"""J0's time gap: the (Huber) squared shortfall of the gap along the path, the same in the fused kernel, and a cut-in
answered by braking in the lane, not by a swerve."""

import numpy as np
import pytest

from agentic_mpc import vehicle
from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import (
    Leader,
    Mandatory,
    MovingDisc,
    PathTracking,
    Rollouts,
    Specification,
    StepContext,
    Surroundings,
    TrackingReference,
)
from agentic_mpc.vehicle import PAPER_PARAMS


def hand_rollouts(x: np.ndarray, y: np.ndarray, v: np.ndarray) -> Rollouts:
    zeros = np.zeros_like(x)
    return Rollouts(x, y, zeros, v, zeros, zeros, zeros, zeros, zeros)


def test_time_gap_cost_is_the_huber_shortfall_along_the_path():
    horizon = 4
    k = np.arange(1, horizon + 1)
    # The contact point moves at 10 m/s from x = 30 m along a path that runs along +x.
    leader = Leader(np.column_stack([30.0 + 0.4 * k, np.zeros(horizon)]), np.tile([1.0, 0.0], (horizon, 1)))
    context = StepContext(np.zeros(4), horizon, PAPER_PARAMS, Surroundings(leaders=(leader,)))
    x = np.column_stack([0.0 + 0 * k, 20.0 + 0 * k, 20.0 + 0 * k, 20.0 + 0 * k, 29.0 + 0 * k]).astype(float)
    y = np.column_stack([0 * k, 0 * k, 1.5 + 0 * k, 0 * k, 0 * k]).astype(float)
    v = np.column_stack([20 + 0 * k, 10 + 0 * k, 10 + 0 * k, 5 + 0 * k, 0 * k]).astype(float)
    rollouts = hand_rollouts(x, y, v)
    mandatory = Mandatory(time_gap_s=1.2, standstill_gap_m=2.0, time_gap_weight=8.0, time_gap_quadratic_m=2.0)
    on = mandatory.prepare(context).cost(rollouts)
    off = Mandatory(time_gap_weight=0.0).prepare(context).cost(rollouts)
    shortfall = np.maximum(0.0, 1.2 * v + 2.0 - (leader.contact_points[:, 0:1] - x))
    # Squared up to 2 m (the last sample, 0.6 m short), then linear with the same slope (the second, 3.2-4.4 m).
    huber = np.where(shortfall > 2.0, 2.0 * (2.0 * shortfall - 2.0), shortfall**2)
    assert shortfall[:, 4].max() < 2.0 < shortfall[:, 1].min()
    expected = 8.0 / horizon * np.sum(huber, axis=0)
    assert on - off == pytest.approx(expected)
    assert (on - off)[0] == 0.0  # 30 m back at 20 m/s: 30 m > 26 m wanted
    assert (on - off)[1] > 0.0  # 10 m back at 10 m/s: 14 m wanted
    assert (on - off)[2] == pytest.approx((on - off)[1])  # 1.5 m to the side opens nothing
    assert (on - off)[3] < (on - off)[1]  # slower, the same place: less is wanted
    assert (on - off)[4] > 0.0  # standing 1 m from its bumper: inside the standstill gap


def test_the_fused_kernel_scores_the_time_gap_as_the_reference_does():
    horizon, samples = 50, 256
    k = np.arange(1, horizon + 1)
    leader = Leader(np.column_stack([18.0 + 0.5 * k, np.full(horizon, 0.5)]), np.tile([1.0, 0.0], (horizon, 1)))
    surroundings = Surroundings(leaders=(leader,))
    controller = FourierMPPI(MPPIConfig(horizon=horizon, samples=samples), seed=3)
    controller.mean = np.random.default_rng(2).normal(size=controller.mean.shape) * 0.4
    state = np.array([0.0, 0.0, 0.05, 18.0])
    z = controller.sample().copy()
    costs = {}
    for weight in (0.0, 10.0):
        prepared = Specification.of(Mandatory(time_gap_weight=weight)).prepare(controller.context(state, surroundings))
        fast, used_fast = controller.costs(prepared, state, z)
        assert used_fast
        costs[weight] = fast.copy()
        assert np.allclose(fast, prepared.cost(controller.rollouts(state, z)), rtol=1e-10, atol=1e-10)
    added = costs[10.0] - costs[0.0]
    assert added.min() > 0.0  # 17 m ahead at 18 m/s: every sample falls short somewhere


def car_discs(centres: np.ndarray, radius_m: float = 2.4) -> tuple[MovingDisc, ...]:
    """A 4.5 m car inflated by a 5.2 m ego: a row of discs along +x (as the SUMO surroundings cover it)."""
    return tuple(MovingDisc(centres + [offset, 0.0], radius_m) for offset in (-2.9, -1.45, 0.0, 1.45, 2.9))


def drive_behind_cut_in(time_gap_weight: float, steps: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """The ego at 20 m/s on its lane (y = 0, corridor +-1.75 m); a car lands 6 m ahead of its bumper at 15 m/s.
    Returns the ego's states and the leader's centre x over the steps."""
    horizon = MPPIConfig().horizon
    dt = PAPER_PARAMS.dt_s
    lane = LanePath(np.column_stack([np.linspace(-50, 1000, 1051), np.zeros(1051)]))
    spec = Specification.of(Mandatory(time_gap_weight=time_gap_weight),
                            PathTracking(path=lane, v_ref_mps=20.0, lateral_weight=5.0))
    controller = FourierMPPI(seed=4)
    state = np.array([0.0, 0.0, 0.0, 20.0])
    leader_x = 0.5 * (5.2 + 4.5) + 6.0
    tangents = np.tile([1.0, 0.0], (horizon, 1))
    k = np.arange(1, horizon + 1)
    states, leader_xs = [], []
    for _ in range(steps):
        future = leader_x + 15.0 * dt * k
        centres = np.column_stack([future, np.zeros(horizon)])
        ahead = np.column_stack([state[0] + max(state[3], 1.0) * dt * k, np.zeros(horizon)])
        surroundings = Surroundings(
            moving_discs=car_discs(centres),
            road_left_edge=TrackingReference(ahead + [0.0, 1.75], tangents),
            road_right_edge=TrackingReference(ahead - [0.0, 1.75], tangents),
            leaders=(Leader(np.column_stack([future - 0.5 * (4.5 + 5.2), np.zeros(horizon)]), tangents),),
        )
        out = controller.step(state, spec, surroundings)
        state = vehicle.step(state, out.delta, out.throttle, out.brake, PAPER_PARAMS)
        leader_x += 15.0 * dt
        states.append(state)
        leader_xs.append(leader_x)
    return np.array(states), np.array(leader_xs)


def test_a_cut_in_is_answered_by_braking_in_the_lane():
    states, leader_x = drive_behind_cut_in(time_gap_weight=Mandatory().time_gap_weight)
    gap = leader_x - states[:, 0] - 0.5 * (4.5 + 5.2)
    assert gap.min() > 0.0  # no contact
    assert np.abs(states[:, 1]).max() < 0.5  # stays in its lane
    assert states[:, 3].min() < 15.0  # fell back below the leader's speed to open the gap
    assert gap[-1] / states[-1, 3] > 0.6  # and the gap is opening towards the time gap after 4 s


def test_the_plain_world_hands_j0_the_nearest_vehicle_ahead_on_the_tracked_lane():
    from agentic_mpc.world.plain import EGO_LENGTH_M, PlainWorld
    from agentic_mpc.world.plain_config import EgoPlacement, PlainConfig, ScriptedVehicle

    config = PlainConfig(
        ego=EgoPlacement(x_m=0.0, lane="center", speed_mps=15.0),
        vehicles=(
            ScriptedVehicle(id="near", lane="center", x_m=30.0, desired_speed_mps=10.0),
            ScriptedVehicle(id="far", lane="center", x_m=60.0, desired_speed_mps=10.0),
            ScriptedVehicle(id="beside", lane="left", x_m=15.0, desired_speed_mps=10.0),
        ),
    )
    world = PlainWorld(config)
    horizon = 50
    (leader,) = world.surroundings(horizon, world.lane("center")[1]).leaders
    k = np.arange(1, horizon + 1)
    assert leader.contact_points[:, 0] == pytest.approx(30.0 - 2.0 - EGO_LENGTH_M / 2 + 10.0 * 0.04 * k)
    assert leader.contact_points[:, 1] == pytest.approx(np.full(horizon, config.road.lane_y_m("center")))
    (left,) = world.surroundings(horizon, world.lane("left")[1]).leaders  # tracking the left lane: "beside"
    assert left.contact_points[0, 0] == pytest.approx(15.0 - 2.0 - EGO_LENGTH_M / 2 + 0.4)


def test_after_a_cut_in_the_wanted_gap_grows_from_the_gap_now_at_the_recovery_rate():
    horizon = 4
    k = np.arange(1, horizon + 1)
    leader = Leader(np.column_stack([30.0 + 0.4 * k, np.zeros(horizon)]), np.tile([1.0, 0.0], (horizon, 1)))
    # The ego is at x = 25 m now: 5.4 m from the first contact point, far inside the wanted 1.2 s x 15 m/s + 2 m.
    context = StepContext(np.array([25.0, 0.0, 0.0, 15.0]), horizon, PAPER_PARAMS, Surroundings(leaders=(leader,)))
    x = np.column_stack([25.0 + 0.6 * k, 25.0 + 0.3 * k]).astype(float)  # holding 15 m/s / falling back
    v = np.column_stack([15.0 + 0 * k, 7.5 + 0 * k]).astype(float)
    rollouts = hand_rollouts(x, np.zeros_like(x), v)
    mandatory = Mandatory(time_gap_weight=8.0, time_gap_quadratic_m=100.0, time_gap_recovery_mps=3.0)
    added = mandatory.prepare(context).cost(rollouts) - Mandatory(time_gap_weight=0.0).prepare(context).cost(rollouts)
    gap = leader.contact_points[:, 0:1] - x
    wanted = np.minimum(1.2 * v + 2.0, 5.4 + 3.0 * 0.04 * k[:, None])  # not 20 m at once: 5.4 m + 3 m/s x t
    assert wanted[:, 0] == pytest.approx(5.4 + 0.12 * k)
    assert added == pytest.approx(8.0 / horizon * np.sum(np.maximum(0.0, wanted - gap) ** 2, axis=0))
    assert added[1] < added[0]  # falling back still pays
