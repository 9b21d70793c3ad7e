"""A follower's disc (a vehicle coming from behind in a lane beside): J0 charges a plan only as far as it comes
closer to the vehicle's line while the ego stands, so a car standing where the follower's cover sweeps is not pushed
to race it; a moving car is pushed away as by any disc."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import Mandatory, MovingDisc, Specification, Surroundings
from agentic_mpc.primitives.base import FOLLOWER_APPROACH_RAMP_M, STANDING_PLAN_MPS

HORIZON = MPPIConfig().horizon
GAP_NOW_M = 2.2  # the follower's line is 2.2 m to the ego's left; its cover (2.6 m) reaches over the ego


def _disc(side: float) -> MovingDisc:
    k = np.arange(1, HORIZON + 1)[:, None]
    centres = np.hstack([-6.0 + 8.0 * 0.04 * k, np.full_like(k, GAP_NOW_M, dtype=float)])  # passing at 8 m/s
    return MovingDisc(centres, 2.6, np.tile([1.0, 0.0], (HORIZON, 1)), (2.3, 0.9), 2.3,
                      follower_side=side, follower_gap_now_m=GAP_NOW_M if side else 0.0)


def _clearance_costs(side: float, backend: str, v_mps: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """J0's clearance cost of three plans from a stand at the origin, heading along x: stand; pull out to the left;
    pull out to the right. And how far left each plan ends."""
    controller = FourierMPPI(MPPIConfig(samples=3, antithetic=False, backend=backend), seed=0)
    state = np.array([0.0, 0.0, 0.0, v_mps])
    only_clearance = Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0,
                               steer_smoothness_weight=0.0, lane_line_standing_weight=0.0)
    spec = Specification.of(mandatory=only_clearance)
    z = np.zeros((2, controller.config.coefficients, 3))
    z[1, 0, 0] = -0.5  # stand
    z[0, 0, 1], z[1, 0, 1] = 0.8, 0.6  # left
    z[0, 0, 2], z[1, 0, 2] = -0.8, 0.6  # right
    surroundings = Surroundings(moving_discs=(_disc(side),))
    costs, _ = controller.costs(spec.prepare(controller.context(state, surroundings)), state, z)
    return costs.copy(), controller.rollouts(state, z).y_m[-1]


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_standing_or_pulling_away_pays_nothing_pulling_towards_it_pays(backend):
    costs, end_left_m = _clearance_costs(1.0, backend)
    plain, _ = _clearance_costs(0.0, backend)
    assert plain[0] > 20.0  # charged as any disc, standing pays for the cover sweeping over it
    assert costs[0] == 0.0 and costs[2] == 0.0  # as a follower's: standing, or pulling out to the right, is free
    assert end_left_m[1] > FOLLOWER_APPROACH_RAMP_M  # the left plan comes closer by more than the ramp ...
    assert 0.0 < costs[1] <= plain[1]  # ... and pays, in full for the stages once it has come that close



@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_moving_car_pays_for_a_followers_disc_as_for_any(backend):
    moving, _ = _clearance_costs(1.0, backend, v_mps=STANDING_PLAN_MPS)
    plain, _ = _clearance_costs(0.0, backend, v_mps=STANDING_PLAN_MPS)
    assert moving[0] > 20.0 and np.array_equal(moving, plain)


def test_fast_path_equals_reference_for_a_follower_disc():
    spec = Specification.of()
    controller = FourierMPPI(MPPIConfig(samples=256), seed=3)
    controller.mean = np.random.default_rng(2).normal(size=controller.mean.shape) * 0.4
    state = np.array([0.0, 0.0, 0.0, 0.5])
    surroundings = Surroundings(moving_discs=(_disc(1.0), _disc(-1.0)))  # also one (mirrored) on the right
    prepared = spec.prepare(controller.context(state, surroundings))
    z = controller.sample().copy()
    fast, used_fast = controller.costs(prepared, state, z)
    fast = fast.copy()
    reference = prepared.cost(controller.rollouts(state, z))
    assert used_fast and np.allclose(fast, reference, rtol=1e-10, atol=1e-10)
    rollouts = controller.rollouts(state, z)

    def clearance(*discs: MovingDisc) -> np.ndarray:
        return spec.prepare(controller.context(state, Surroundings(moving_discs=discs))).cost(rollouts)

    gated, plain = clearance(_disc(1.0)) - clearance(), clearance(_disc(0.0)) - clearance()
    partly = (gated > 1e-9) & (gated < plain - 1e-9)
    assert np.count_nonzero(partly) > 10  # the ramp is exercised, not only 0 and the full charge
