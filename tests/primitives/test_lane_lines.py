"""J0's lane lines: a plan that ends standing across a line between lanes pays; in a lane, or moving, it does not."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import LaneLines, Mandatory, Specification, Surroundings
from agentic_mpc.vehicle import PAPER_PARAMS

HALF_LENGTH_M, HALF_WIDTH_M = 2.3, 0.9
WEIGHT = 50.0


def _lines() -> LaneLines:
    """A straight road along x with lines between its lanes at y = +-1.75, sampled every metre for 60 m."""
    along = np.arange(-5.0, 55.0)
    return LaneLines(np.column_stack([along, np.zeros_like(along)]), np.tile([1.0, 0.0], (along.size, 1)), 1.0,
                     (-1.75, 1.75), HALF_LENGTH_M, HALF_WIDTH_M)


def _constant_plan_cost(y_m: float, v_mps: float = 2.0, phi_rad: float = 0.0, hold: bool = False,
                        backend: str = "fast") -> float:
    """J0's cost of the plan 'brake to a stand' (or, with ``hold``, 'roll on at v') from (0, y_m) at v_mps and
    heading phi_rad, straight on."""
    controller = FourierMPPI(MPPIConfig(samples=2, antithetic=False, backend=backend), seed=0)
    state = np.array([0.0, y_m, phi_rad, v_mps])
    spec = Specification.of(mandatory=Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0,
                                                lane_line_standing_weight=WEIGHT))
    context = controller.context(state, Surroundings(lane_lines=_lines()))
    z = np.zeros((2, controller.config.coefficients, 1))
    z[1, 0, 0] = -PAPER_PARAMS.w_v * v_mps / PAPER_PARAMS.w_a if hold else -1.0
    costs, _ = controller.costs(spec.prepare(context), state, z)
    return float(costs[0])


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_standing_on_a_line_pays_for_how_far_the_body_reaches_over_it(backend):
    # centred on the line: the body reaches its half width over it
    assert _constant_plan_cost(1.75, backend=backend) == pytest.approx(WEIGHT * HALF_WIDTH_M**2)
    # 0.5 m right of the line: 0.4 m over
    assert _constant_plan_cost(1.25, backend=backend) == pytest.approx(WEIGHT * 0.4**2)
    # in the lane's middle, and at its edge with the body just inside: nothing
    assert _constant_plan_cost(0.0, backend=backend) == 0.0
    assert _constant_plan_cost(1.75 - HALF_WIDTH_M - 0.01, backend=backend) == 0.0
    assert _constant_plan_cost(-3.5, backend=backend) == 0.0


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_turned_body_reaches_further(backend):
    # 1.1 m right of the line the body is clear of it; stood angled 0.15 rad towards it, a corner reaches over
    assert _constant_plan_cost(0.65, backend=backend) == 0.0
    reach = HALF_LENGTH_M * np.sin(0.15) + HALF_WIDTH_M * np.cos(0.15)
    # braking from 2 m/s it still rolls 0.37 m, 0.055 m of it towards the line: it stands 1.045 m from it
    assert _constant_plan_cost(0.65, phi_rad=0.15, backend=backend) == pytest.approx(WEIGHT * (reach - 1.045) ** 2,
                                                                                     rel=0.02)


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_moving_across_a_line_or_already_standing_on_one_pays_nothing(backend):
    assert _constant_plan_cost(1.75, v_mps=5.0, hold=True, backend=backend) == 0.0  # a lane change at 5 m/s
    # a car that already stands across a line can only leave it by moving on: its stand is not charged (in front of
    # three stopped cars abreast it crept at centimetres to get off the line)
    assert _constant_plan_cost(1.75, v_mps=0.0, backend=backend) == 0.0
