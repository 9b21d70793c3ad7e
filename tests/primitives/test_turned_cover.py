"""J0's covers grow when the ego is turned against the vehicle they cover: its corner reaches further."""

import math

import numpy as np
import pytest

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.primitives import Mandatory, MovingDisc, Specification, Surroundings

HALF_LENGTH_M, HALF_WIDTH_M = 2.6, 0.95  # the paper's car
RADIUS_M, CENTRE_AT_M = 2.0, 2.3  # a cover 2.3 m to the left of the ego's centre: aligned, the ego is outside


def _standing_cost(ego_heading_rad: float, cover_heading_rad: float = 0.0, extents=(HALF_LENGTH_M, HALF_WIDTH_M),
                   headings: bool = True, backend: str = "fast", cover_radius_m: float | None = None) -> float:
    """J0's clearance cost of standing still at the origin with heading ``ego_heading_rad`` beside one disc."""
    controller = FourierMPPI(MPPIConfig(samples=2, antithetic=False, backend=backend), seed=0)
    h = controller.config.horizon
    state = np.array([0.0, 0.0, ego_heading_rad, 0.0])
    centres = np.tile([0.0, CENTRE_AT_M], (h, 1))
    towards = np.tile([math.cos(cover_heading_rad), math.sin(cover_heading_rad)], (h, 1))
    if cover_radius_m is None:  # the cover is the bodies'
        disc = MovingDisc(centres, RADIUS_M, towards if headings else None, extents)
    else:  # a wider cover (a lane's): the bodies' radius grows, the cover's is the floor
        disc = MovingDisc(centres, cover_radius_m, towards if headings else None, extents, RADIUS_M)
    mandatory = Mandatory(brake_effort_weight=0.0, throttle_brake_smoothness_weight=0.0, time_gap_weight=0.0)
    prepared = Specification.of(mandatory=mandatory).prepare(controller.context(state, Surroundings((disc,))))
    z = np.zeros((2, controller.config.coefficients, 1))
    z[1, 0, 0] = -1.0  # full brake: the car stays where it is
    if backend == "reference":
        return float(prepared.cost(controller.rollouts(state, z))[0])
    costs, used_fast = controller.costs(prepared, state, z)
    assert used_fast
    return float(costs[0])


def _expected(relative_rad: float) -> float:
    grown = RADIUS_M + max(0.0, HALF_LENGTH_M * abs(math.sin(relative_rad))
                           - HALF_WIDTH_M * (1.0 - abs(math.cos(relative_rad))))
    return 200.0 * (2.0 - CENTRE_AT_M**2 / grown**2) if CENTRE_AT_M < grown else 0.0  # per stage, mean over H


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_an_aligned_ego_outside_the_cover_pays_nothing(backend):
    assert _standing_cost(0.0, backend=backend) == 0.0
    assert _standing_cost(0.3, cover_heading_rad=0.3, backend=backend) == 0.0  # turned with the other car


@pytest.mark.parametrize("backend", ["fast", "reference"])
@pytest.mark.parametrize("heading_rad", [0.1, 0.2, -0.2, math.pi - 0.2])
def test_a_turned_ego_pays_as_its_corner_reaches_in(heading_rad, backend):
    """At 0.2 rad (11.5 deg) the corner reaches 0.50 m further: the 2.3 m disc edge is inside 2.50 m."""
    expected = _expected(heading_rad)
    if abs(heading_rad) == 0.1:
        assert expected == 0.0  # 0.24 m further: still outside
    else:
        assert expected > 10.0
    assert _standing_cost(heading_rad, backend=backend) == pytest.approx(expected, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_cover_without_a_heading_or_extents_keeps_its_radius(backend):
    assert _standing_cost(0.3, headings=False, backend=backend) == 0.0
    assert _standing_cost(0.3, extents=(0.0, 0.0), backend=backend) == 0.0


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_a_wider_cover_grows_only_once_the_bodies_reach_past_it(backend):
    """A lane's cover (2.8 m) around a 2.0 m body: turned 0.2 rad the body reaches 2.50 m, inside the lane's
    cover, which stays as it is; a 2.2 m cover is outgrown (2.50 m)."""
    wide = 200.0 * (2.0 - CENTRE_AT_M**2 / 2.8**2)
    assert _standing_cost(0.0, cover_radius_m=2.8, backend=backend) == pytest.approx(wide, rel=1e-12)
    assert _standing_cost(0.2, cover_radius_m=2.8, backend=backend) == pytest.approx(wide, rel=1e-12)
    assert _standing_cost(0.0, cover_radius_m=2.2, backend=backend) == 0.0
    assert _standing_cost(0.2, cover_radius_m=2.2, backend=backend) == pytest.approx(_expected(0.2), rel=1e-9)
