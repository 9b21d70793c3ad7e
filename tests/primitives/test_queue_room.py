"""J0's queue room behind a blockage: how far back a plan may end, worked out from the model's geometry."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import Blockage, Mandatory, PathTracking, Specification, Surroundings
from agentic_mpc.vehicle import PAPER_PARAMS, step

RADIUS_M = 2.4  # a car's cover: (1.8 + 1.8) / 2 + 0.5 margin


def test_pull_out_distance_follows_the_slip_angle_and_the_turning_circle():
    radius, cos_gamma, sin_gamma = PAPER_PARAMS.pull_out_turn(1.0)
    assert radius == pytest.approx(32.05, abs=0.01)  # l_r / sin(gamma)
    assert np.degrees(np.arctan2(sin_gamma, cos_gamma)) == pytest.approx(14.79, abs=0.01)
    assert PAPER_PARAMS.pull_out_distance_m(0.0, 0.5) == pytest.approx(0.0, abs=1e-9)
    assert PAPER_PARAMS.pull_out_distance_m(100.0, 1.0) == float("inf")  # the circle turns back first


@pytest.mark.parametrize("steer, expected_m", [(1.0, 6.31), (0.5, 10.79)])
def test_pull_out_distance_is_what_the_model_drives(steer, expected_m):
    """The closed form against the paper's model stepped at 0.1 m/s (4 mm a step) with the steering held."""
    state = np.array([0.0, 0.0, 0.0, 0.1])
    while state[1] < RADIUS_M:
        previous = state
        state = step(state, steer, 0.0, 0.0)
        state[3] = 0.1
    along = previous[0] + (state[0] - previous[0]) * (RADIUS_M - previous[1]) / (state[1] - previous[1])
    assert along == pytest.approx(expected_m, abs=0.01)
    assert PAPER_PARAMS.pull_out_distance_m(RADIUS_M, steer) == pytest.approx(along, abs=0.005)


def _standing_costs(distance_m: float, lateral_m: float = 0.0, v_mps: float = 0.0, car_offset_m: float = 0.0
                    ) -> float:
    """J0's cost of the constant plan 'stand still' (or roll on at v) with a blockage ``distance_m`` ahead of
    the ego's centre (to the rear disc's edge), its lane's centre line at y = 0 and the car ``car_offset_m``
    left of it."""
    controller = FourierMPPI(MPPIConfig(samples=2, antithetic=False), seed=0)
    state = np.array([0.0, lateral_m, 0.0, v_mps])
    blockage = Blockage(distance_m + RADIUS_M, 0.0, 1.0, 0.0, RADIUS_M, car_offset_m)
    spec = Specification.of(mandatory=Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0))
    context = controller.context(state, Surroundings(blockages=(blockage,)))
    z = np.zeros((2, controller.config.coefficients, 1))
    z[1, 0, 0] = -1.0 if v_mps == 0.0 else -PAPER_PARAMS.w_v * v_mps / PAPER_PARAMS.w_a  # hold the speed
    costs, _ = controller.costs(spec.prepare(context), state, z)
    return float(costs[0])


def test_room_is_free_beyond_the_pull_out_distance_and_charged_inside_it():
    room = PAPER_PARAMS.pull_out_distance_m(RADIUS_M, 0.5)
    assert _standing_costs(room + 0.1) == 0.0
    # Rolling 2 s at 1 m/s from 1.5 m beyond the room, the plan ends 0.5 m inside it, plus 1 / (2 x 4) m to stop.
    assert _standing_costs(room + 1.5, v_mps=1.0) == pytest.approx(20.0 * (0.5 + 1.0 / 8.0) ** 2, rel=1e-2)


def test_standing_inside_the_room_only_the_full_locks_room_is_charged():
    """Inside the room worked out for half lock, a standing car gets out only near full lock, and every plan on the
    way ended closer than the half lock's room: it paid more than standing, and the ego stood 20-110 s behind the
    curve's stopped car (seeds 3804, 3808). Standing there, the room is the full lock's."""
    room, full = PAPER_PARAMS.pull_out_distance_m(RADIUS_M, 0.5), PAPER_PARAMS.pull_out_distance_m(RADIUS_M, 1.0)
    assert full < room - 4.0
    assert _standing_costs(room - 1.0) == 0.0
    assert _standing_costs(full - 1.0) == pytest.approx(20.0 * 1.0, rel=1e-6)  # weight x shortfall^2
    assert _standing_costs(0.5) == pytest.approx(20.0 * 2.0 * (2.0 * (full - 0.5) - 2.0), rel=1e-6)  # Huber


def test_room_shrinks_when_partly_aside_and_vanishes_beside():
    assert _standing_costs(5.0, lateral_m=1.5) < _standing_costs(5.0, lateral_m=0.0)
    assert _standing_costs(5.0, lateral_m=RADIUS_M + 0.1) == 0.0


def test_aside_counts_from_the_car_and_in_line_from_its_lane():
    """A car standing 1.5 m right of its lane's centre: an ego 1.5 m right is straight behind it (the whole
    room), one 1.5 m left is 3 m aside of it (no room needed), and one in the next lane to the right (3.5 m)
    is out of the lane's band although it is only 2 m aside of the car."""
    straight_behind = _standing_costs(5.0)
    assert _standing_costs(5.0, lateral_m=-1.5, car_offset_m=-1.5) == pytest.approx(straight_behind, rel=1e-12)
    assert _standing_costs(5.0, lateral_m=1.5, car_offset_m=-1.5) == 0.0
    assert _standing_costs(5.0, lateral_m=0.0, car_offset_m=-1.5) == pytest.approx(
        _standing_costs(5.0, lateral_m=1.5), rel=1e-12)
    assert _standing_costs(5.0, lateral_m=-3.5, car_offset_m=-1.5) == 0.0


def test_a_plan_that_ends_inside_the_rear_disc_past_its_centre_is_not_past_it():
    """Past the disc's centre but inside it is inside the car: it pays more than anywhere behind (counted past, it
    paid nothing, and a plan that drove into the gap between stopped cars abreast was cheaper than standing,
    docs/traffic.md, "Leaving a standstill"). Past the disc, the plan is beside or past the car."""
    assert _standing_costs(-RADIUS_M - 1.0) > _standing_costs(0.5) > 0.0
    assert _standing_costs(-2.0 * RADIUS_M - 0.1) == 0.0


def test_a_moving_plan_wants_its_stopping_distance_on_top():
    room = PAPER_PARAMS.pull_out_distance_m(RADIUS_M, 0.5)
    v = 10.0
    stopping = v * v / (2 * 4.0)  # 12.5 m at the default 4 m/s^2
    # The plan rolls 2 s at 10 m/s: from 42 m it ends 22 m short of the blockage, under room + stopping (23.3 m).
    assert _standing_costs(42.0, v_mps=v) == pytest.approx(20.0 * (room + stopping - 22.0) ** 2, rel=1e-3)
    assert _standing_costs(44.0, v_mps=v) == 0.0


def test_a_car_standing_at_its_room_stays_there_rather_than_creep_in():
    """J1 + J0 from standing exactly at the room: standing beats creeping 1 m and 3 m further in."""
    controller = FourierMPPI(seed=0)
    room = PAPER_PARAMS.pull_out_distance_m(RADIUS_M, 0.5)
    state = np.array([0.0, 0.0, 0.0, 0.0])
    path = PathTracking(path=[(0.0, 0.0), (200.0, 0.0)], v_ref_mps=15.0)
    blockage = Blockage(room + 0.05 + RADIUS_M, 0.0, 1.0, 0.0, RADIUS_M)
    spec = Specification.of(path)
    prepared = spec.prepare(controller.context(state, Surroundings(blockages=(blockage,))))
    z = np.zeros((2, controller.config.coefficients, 3))
    z[1, 0] = [-0.3, 0.11, 0.33]  # stand; creep about 1 m; about 3 m (a constant throttle over the 2 s)
    rolled = controller.rollouts(state, z)
    assert 0.5 < rolled.x_m[-1, 1] < 1.5 and 2.0 < rolled.x_m[-1, 2] < 4.0
    costs, _ = controller.costs(prepared, state, z)
    assert costs[0] < costs[1] < costs[2]
