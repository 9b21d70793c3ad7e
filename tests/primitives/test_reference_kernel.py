"""J1's compiled reference points equal their readable NumPy/shapely definition."""

import numpy as np
import pytest

from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives.reference_kernel import reference_points, reference_points_readable

rng = np.random.default_rng(3)
WAVY = LanePath(np.column_stack([np.linspace(0, 300, 151), 20 * np.sin(np.linspace(0, 300, 151) / 40)]))
CIRCLE = LanePath(np.column_stack([50 * np.cos(np.linspace(0, 1.9 * np.pi, 200)), 50 * np.sin(np.linspace(0, 1.9 * np.pi, 200))]))
STRAIGHT = LanePath.straight((-20.0, 0.0), (400.0, 0.0))


@pytest.mark.parametrize("path", [WAVY, CIRCLE, STRAIGHT], ids=["wavy", "circle", "straight"])
@pytest.mark.parametrize("accel", [3.0, 0.5, None])
def test_kernel_equals_the_readable_definition(path, accel):
    xy = path.coordinates
    lo, hi = xy.min(axis=0) - 30.0, xy.max(axis=0) + 30.0  # beyond both ends too: clamped there
    for _ in range(200):
        x, y = rng.uniform(lo, hi)
        v_now, v_ref = rng.uniform(0.0, 30.0, size=2)
        horizon = int(rng.integers(2, 120))
        fast = reference_points(path, x, y, v_now, v_ref, accel, 0.04, horizon)
        readable = reference_points_readable(path, x, y, v_now, v_ref, accel, 0.04, horizon)
        assert np.allclose(fast[0], readable[0], rtol=0, atol=1e-9)
        assert np.allclose(fast[1], readable[1], rtol=0, atol=1e-12)


def test_points_on_a_straight_lane_are_exact():
    points, tangents = reference_points(STRAIGHT, 10.0, 1.0, 15.0, 15.0, 3.0, 0.04, 50)
    assert np.allclose(points[:, 0], 10.0 + 0.6 * np.arange(1, 51)) and np.all(points[:, 1] == 0.0)
    assert np.all(tangents == [1.0, 0.0])
    # The end of the path is where the reference stops.
    points, _ = reference_points(STRAIGHT, 399.0, 0.0, 30.0, 30.0, None, 0.04, 50)
    assert np.all(points[:, 0] <= 400.0) and points[-1, 0] == 400.0


def test_a_shifted_reference_runs_along_the_lane_beside():
    """Surroundings.reference_shift_m (passing a queue in the lane beside): J1's points move along the left
    normal by the shift, on a bend too, and the tangents stay; a shift of 0 leaves the points as they were."""
    from agentic_mpc.controller import FourierMPPI
    from agentic_mpc.primitives import PathTracking, Surroundings

    controller = FourierMPPI(seed=0)
    state = np.array([45.0, 10.0, 1.8, 12.0])  # on the circle's quarter turn
    j1 = PathTracking(path=CIRCLE.coordinates.tolist(), v_ref_mps=15.0)
    plain = j1.prepare(controller.context(state, Surroundings())).reference
    shifted = j1.prepare(controller.context(state, Surroundings(reference_shift_m=-3.5))).reference
    assert np.array_equal(shifted.tangents, plain.tangents)
    normal = np.column_stack([-plain.tangents[:, 1], plain.tangents[:, 0]])
    assert np.allclose(shifted.points - plain.points, -3.5 * normal, rtol=0, atol=1e-12)
    # The circle's centre is on the left: shifted right, every point is 3.5 m further out (radius 53.5 m).
    assert np.allclose(np.hypot(*shifted.points.T), np.hypot(*plain.points.T) + 3.5, atol=0.02)


def test_a_speed_cap_slows_the_reference_as_a_lower_v_ref_would():
    """Surroundings.reference_speed_cap_mps (coming up to a queue): J1's points are those of v_ref = the cap
    (a ramp down from the ego's speed at reference_accel_mps2); a cap above v_ref changes nothing."""
    from agentic_mpc.controller import FourierMPPI
    from agentic_mpc.primitives import PathTracking, Surroundings

    controller = FourierMPPI(seed=0)
    state = np.array([10.0, 0.0, 0.0, 15.0])
    j1 = PathTracking(path=STRAIGHT.coordinates.tolist(), v_ref_mps=15.0)
    capped = j1.prepare(controller.context(state, Surroundings(reference_speed_cap_mps=6.0))).reference.points
    slower = PathTracking(path=STRAIGHT.coordinates.tolist(), v_ref_mps=6.0)
    assert np.array_equal(capped, slower.prepare(controller.context(state, Surroundings())).reference.points)
    # Down at 3 m/s^2 from 15 m/s: the first step 15 - 0.12 m/s, so 0.04 * 14.88 m further along.
    assert capped[0, 0] == pytest.approx(10.0 + 0.04 * (15.0 - 3.0 * 0.04), abs=1e-9)
    above = j1.prepare(controller.context(state, Surroundings(reference_speed_cap_mps=20.0))).reference.points
    assert np.array_equal(above, j1.prepare(controller.context(state, Surroundings())).reference.points)
