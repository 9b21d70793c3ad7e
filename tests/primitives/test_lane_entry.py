"""J0's lane-entry gap: a plan whose body goes deeper into a neighbour's lane than now keeps a time gap to it."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import LaneNeighbour, Mandatory, Specification, Surroundings
from agentic_mpc.primitives.lane_entry import LANE_ENTRY_RAMP_M

HORIZON = MPPIConfig().horizon
STEPS_S = 0.04 * np.arange(1, HORIZON + 1)[:, None]
LANE_Y_M = 3.5  # the lane to the left: its centre line; the ego drives along y = 0 at 10 m/s
REACH_M = 0.5 * 3.5 + 0.9  # half the lane + the ego's half width


def _neighbour(x0_m: float, speed_mps: float, depth_now_m: float = REACH_M - LANE_Y_M) -> LaneNeighbour:
    along_x = np.tile([1.0, 0.0], (HORIZON, 1))
    centres = np.hstack([x0_m + speed_mps * STEPS_S, np.full_like(STEPS_S, LANE_Y_M)])
    lane_points = np.hstack([10.0 * STEPS_S, np.full_like(STEPS_S, LANE_Y_M)])
    return LaneNeighbour(centres, along_x, lane_points, along_x, REACH_M, 4.6, speed_mps, depth_now_m)


def _gap_costs(neighbour: LaneNeighbour, backend: str, y0_m: float = 0.0) -> np.ndarray:
    """The lane-entry gap's cost of three plans from (0, y0) at 10 m/s: keep the lane; steer left into the
    neighbour's lane; steer left and brake."""
    controller = FourierMPPI(MPPIConfig(samples=3, antithetic=False, backend=backend), seed=0)
    state = np.array([0.0, y0_m, 0.0, 10.0])
    z = np.zeros((2, controller.config.coefficients, 3))
    z[1, 0, :] = 0.1  # about the throttle that holds 10 m/s
    z[0, 0, 1] = 0.5
    z[0, 0, 2], z[1, 0, 2] = 0.5, -0.6

    def cost(weight: float) -> np.ndarray:
        spec = Specification.of(mandatory=Mandatory(lane_entry_gap_weight=weight))
        prepared = spec.prepare(controller.context(state, Surroundings(lane_neighbours=(neighbour,))))
        return controller.costs(prepared, state, z)[0].copy()

    return cost(10.0) - cost(0.0)


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_merging_in_front_of_a_car_alongside_pays_keeping_the_lane_does_not(backend):
    costs = _gap_costs(_neighbour(-2.0, 11.0), backend)  # alongside, a little faster
    assert costs[0] == 0.0
    assert costs[1] > 100.0


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_gap_of_the_time_gap_and_more_costs_nothing(backend):
    assert _gap_costs(_neighbour(-60.0, 10.0), backend)[1] == 0.0  # 60 m behind at the same speed
    assert _gap_costs(_neighbour(80.0, 10.0), backend)[1] == 0.0  # 80 m ahead
    # 25 m ahead and much slower: merging in behind it at 10 m/s closes to within the time gap
    assert _gap_costs(_neighbour(25.0, 2.0), backend)[1] > 0.0


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_car_already_partly_in_the_lane_pays_only_for_going_deeper(backend):
    # the ego 1 m left of its lane's centre: 0.25 m in the neighbour's lane now, a car alongside
    depth_now = REACH_M - (LANE_Y_M - 1.0)
    neighbour = _neighbour(-2.0, 11.0, depth_now)
    costs = _gap_costs(neighbour, backend, y0_m=1.0)
    assert costs[0] == 0.0  # holding its place
    assert costs[1] > 100.0  # going deeper
    assert LANE_ENTRY_RAMP_M < 0.25


def test_fast_path_equals_reference_for_lane_neighbours():
    spec = Specification.of(mandatory=Mandatory(lane_entry_gap_weight=10.0))
    controller = FourierMPPI(MPPIConfig(samples=256), seed=3)
    controller.mean = np.random.default_rng(2).normal(size=controller.mean.shape) * 0.4
    state = np.array([0.0, 0.5, 0.05, 10.0])
    neighbours = (_neighbour(-8.0, 12.0), _neighbour(15.0, 8.0))
    prepared = spec.prepare(controller.context(state, Surroundings(lane_neighbours=neighbours)))
    z = controller.sample().copy()
    fast, used_fast = controller.costs(prepared, state, z)
    fast = fast.copy()
    reference = prepared.cost(controller.rollouts(state, z))
    assert used_fast and np.allclose(fast, reference, rtol=1e-10, atol=1e-10)
    off = Specification.of(mandatory=Mandatory(lane_entry_gap_weight=0.0)).prepare(
        controller.context(state, Surroundings(lane_neighbours=neighbours))).cost(controller.rollouts(state, z))
    assert np.count_nonzero(reference - off > 1e-9) > 10  # the term is exercised
