"""J0's contact term: inside a disc, a plan whose body touches the other's pays far more than one in the margin."""

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import Mandatory, MovingDisc, Specification, Surroundings

RADIUS_M = 2.4  # two cars' half widths (1.9 m) + the 0.5 m clearance margin
CONTACT_WEIGHT = 3000.0


def _costs(centre_m: tuple[float, float], backend: str, v_mps: float = 0.0, contact_weight: float = CONTACT_WEIGHT,
           hold: bool = True) -> float:
    """J0's clearance cost of a plan from the origin (heading +x, at ``v_mps``) beside one disc at ``centre_m``:
    holding its speed (``hold``) or braking to a stand at full brake."""
    controller = FourierMPPI(MPPIConfig(samples=2, antithetic=False, backend=backend), seed=0)
    h = controller.config.horizon
    state = np.array([0.0, 0.0, 0.0, v_mps])
    disc = MovingDisc(np.tile(centre_m, (h, 1)), RADIUS_M)
    mandatory = Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0, time_gap_weight=0.0,
                          vehicle_contact_weight=contact_weight)
    prepared = Specification.of(mandatory=mandatory).prepare(controller.context(state, Surroundings((disc,))))
    z = np.zeros((2, controller.config.coefficients, 1))
    z[1, 0, 0] = 0.0 if hold else -1.0
    if backend == "reference":
        return float(prepared.cost(controller.rollouts(state, z))[0])
    costs, used_fast = controller.costs(prepared, state, z)
    assert used_fast
    return float(costs[0])


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_in_the_margin_only_the_clearance_is_charged(backend):
    # 2.0 m beside: inside the 2.4 m cover, outside the 0.8 x 2.4 = 1.92 m where the bodies touch.
    assert _costs((0.0, 2.0), backend, hold=False) == pytest.approx(200.0 * (2.0 - 2.0**2 / RADIUS_M**2))
    assert _costs((0.0, 2.0), backend, hold=False) == pytest.approx(_costs((0.0, 2.0), backend, contact_weight=0.0,
                                                                           hold=False))


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_standing_car_is_not_charged_for_a_contact_it_does_not_drive_into(backend):
    # 1.5 m beside, the bodies touch: standing still, the ego cannot get away from it by fleeing into something
    # else (4435: an ambulance squeezing past made a standing ego throttle into the stopped car ahead).
    clearance = 200.0 * (2.0 - 1.5**2 / RADIUS_M**2)
    assert _costs((0.0, 1.5), backend, hold=False) == pytest.approx(clearance)


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_driving_into_the_body_ahead_costs_the_contact_on_top(backend):
    # 3 m ahead at 2 m/s: the plan that holds its speed drives 4 m on, through the other's body.
    into = _costs((3.0, 0.0), backend, v_mps=2.0) - _costs((3.0, 0.0), backend, v_mps=2.0, contact_weight=0.0)
    assert into > 0.1 * CONTACT_WEIGHT  # over a fifth of the horizon in contact, most of it deep
    # Behind the ego (it drives away), or beside it at a stand, the same depth costs no contact.
    away = _costs((-1.0, 0.0), backend, v_mps=2.0) - _costs((-1.0, 0.0), backend, v_mps=2.0, contact_weight=0.0)
    assert away == pytest.approx(0.0, abs=1e-9)


def _alongside_contact(ego_heading_rad: float, other_heading_rad: float, backend: str) -> float:
    """The contact term's share of J0 for a plan holding 10 m/s beside a car 1.5 m to the left at 10 m/s, its
    centres along +x (its lane), its body turned by ``other_heading_rad``."""
    controller = FourierMPPI(MPPIConfig(samples=2, antithetic=False, backend=backend), seed=0)
    h = controller.config.horizon
    state = np.array([0.0, 0.0, ego_heading_rad, 10.0])
    k = np.arange(1, h + 1)[:, None]
    turned = np.tile([np.cos(other_heading_rad), np.sin(other_heading_rad)], (h, 1))
    disc = MovingDisc(np.hstack([10.0 * 0.04 * k, np.full_like(k, 1.5, dtype=float)]), RADIUS_M, turned)
    z = np.zeros((2, controller.config.coefficients, 1))
    costs = []
    for weight in (CONTACT_WEIGHT, 0.0):
        mandatory = Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0, time_gap_weight=0.0,
                              vehicle_contact_weight=weight)
        prepared = Specification.of(mandatory=mandatory).prepare(controller.context(state, Surroundings((disc,))))
        if backend == "reference":
            costs.append(float(prepared.cost(controller.rollouts(state, z))[0]))
        else:
            costs.append(float(controller.costs(prepared, state, z)[0][0]))
    return costs[0] - costs[1]


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_lane_change_into_a_car_alongside_pays_the_contact_its_turn_into_the_ego_does_not(backend):
    assert _alongside_contact(0.1, 0.0, backend) > 0.05 * CONTACT_WEIGHT  # the ego turns in (3602: at fault)
    assert _alongside_contact(0.0, -0.1, backend) == pytest.approx(0.0, abs=1e-9)  # the other's body turns in
    assert _alongside_contact(0.0, 0.0, backend) == pytest.approx(0.0, abs=1e-9)  # side by side


def test_fast_path_equals_reference_where_plans_touch():
    mandatory = Mandatory(vehicle_contact_weight=CONTACT_WEIGHT)
    controller = FourierMPPI(MPPIConfig(samples=256), seed=4)
    controller.mean = np.random.default_rng(6).normal(size=controller.mean.shape) * 0.4
    h = controller.config.horizon
    state = np.array([0.0, 0.0, 0.0, 3.0])
    k = np.arange(1, h + 1)[:, None]
    # A car 5 m ahead crawling at 0.5 m/s, turned 0.2 rad, and one standing 2.2 m to the right.
    ahead = MovingDisc(np.hstack([5.0 + 0.02 * k, np.zeros_like(k, dtype=float)]), 2.55,
                       np.tile([np.cos(0.2), np.sin(0.2)], (h, 1)), (2.6, 0.95), 2.4)
    beside = MovingDisc(np.tile([0.5, -2.2], (h, 1)), 2.4, None, (0.0, 0.0), None)
    prepared = Specification.of(mandatory=mandatory).prepare(controller.context(state, Surroundings((ahead, beside))))
    z = controller.sample().copy()
    fast, used_fast = controller.costs(prepared, state, z)
    fast = fast.copy()
    rollouts = controller.rollouts(state, z)
    reference = prepared.cost(rollouts)
    assert used_fast and np.allclose(fast, reference, rtol=1e-10, atol=1e-10)
    no_contact = Specification.of(mandatory=mandatory.model_copy(update={"vehicle_contact_weight": 0.0}))
    plain = no_contact.prepare(controller.context(state, Surroundings((ahead, beside)))).cost(rollouts)
    assert np.count_nonzero(reference > plain + 1e-6) > 10  # the contact term is exercised, not only the margin
