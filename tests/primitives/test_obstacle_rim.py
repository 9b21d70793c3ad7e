"""J2's rim: a moving car's plan that ends standing on a circle's rim (or in it) pays; beyond the rim, moving on, or
already standing, it does not."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import Circle, Mandatory, ObstacleAvoidance, Specification
from agentic_mpc.primitives.obstacle_avoidance import STANDING_RIM_M, STANDING_RIM_WEIGHT
from agentic_mpc.vehicle import PAPER_PARAMS

CIRCLE = Circle(x_m=10.0, y_m=0.0, radius_m=2.4)


def _j2_cost(y_m: float, v_mps: float = 2.0, hold: bool = False, backend: str = "fast") -> tuple[float, float]:
    """J2's cost of the plan 'brake to a stand' (or, with ``hold``, 'roll on at v') from (9.6, y_m) heading along x,
    and the distance from the circle's centre at which the plan ends."""
    controller = FourierMPPI(MPPIConfig(samples=2, antithetic=False, backend=backend), seed=0)
    state = np.array([9.6, y_m, 0.0, v_mps])
    # J0 without the terms a braking plan pays, so that the total is J2's
    spec = Specification.of(ObstacleAvoidance(obstacles=(CIRCLE,)),
                            mandatory=Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0))
    z = np.zeros((2, controller.config.coefficients, 1))
    z[1, 0, 0] = -PAPER_PARAMS.w_v * v_mps / PAPER_PARAMS.w_a if hold else -1.0
    costs, _ = controller.costs(spec.prepare(controller.context(state)), state, z)
    end = controller.rollouts(state, z)
    return float(costs[0]), float(np.hypot(end.x_m[-1, 0] - CIRCLE.x_m, end.y_m[-1, 0] - CIRCLE.y_m))


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_stand_on_the_rim_pays_for_how_far_inside_rim_and_margin_it_ends(backend):
    cost, distance_m = _j2_cost(2.6, backend=backend)  # stands 0.2 m outside the rim
    assert 2.4 < distance_m < 2.9
    assert cost == pytest.approx(STANDING_RIM_WEIGHT * (2.4 + STANDING_RIM_M - distance_m) ** 2)
    assert _j2_cost(3.0, backend=backend)[0] == 0.0  # beyond rim and margin: nothing


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_moving_past_the_rim_or_already_standing_there_pays_nothing(backend):
    assert _j2_cost(2.6, v_mps=5.0, hold=True, backend=backend)[0] == 0.0  # rolling past at 5 m/s
    # a car already standing on the rim is not charged for its stand (only what J2 charges inside, per stage)
    assert _j2_cost(2.6, v_mps=0.0, backend=backend)[0] == 0.0


def test_fast_path_equals_reference_for_slow_plans_near_circles():
    spec = Specification.of(ObstacleAvoidance(obstacles=(CIRCLE, Circle(x_m=13.0, y_m=3.5, radius_m=2.0))))
    controller = FourierMPPI(MPPIConfig(samples=256), seed=3)
    controller.mean = np.random.default_rng(2).normal(size=controller.mean.shape) * 0.4
    state = np.array([9.0, 2.7, 0.05, 1.5])
    prepared = spec.prepare(controller.context(state))
    z = controller.sample().copy()
    fast, used_fast = controller.costs(prepared, state, z)
    fast = fast.copy()
    reference = prepared.cost(controller.rollouts(state, z))
    assert used_fast and np.allclose(fast, reference, rtol=1e-10, atol=1e-10)
    rim_only = reference - Specification.of(ObstacleAvoidance(obstacles=spec.primitives[-1].obstacles)).prepare(
        controller.context(np.array([9.0, 2.7, 0.05, 0.0]))).cost(controller.rollouts(state, z))
    assert np.count_nonzero(rim_only > 0) > 10  # the rim term is exercised, not only J2's stages
