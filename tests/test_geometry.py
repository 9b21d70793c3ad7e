"""Lane paths: arc length, projection and the paper's reference points, on curves too."""

import numpy as np
import pytest

from agentic_mpc.geometry import LanePath, PathError

RADIUS_M = 50.0


def arc(radius=RADIUS_M, vertices=2001):
    """A quarter circle, counter-clockwise (turning left), centred on the origin."""
    theta = np.linspace(-np.pi / 2, 0.0, vertices)
    return LanePath(np.column_stack([radius * np.cos(theta), radius * np.sin(theta)]), name="arc")


def test_reference_points_on_a_curve_are_spaced_by_arc_length():
    path = arc()
    v_ref, dt, horizon = 15.0, 0.04, 50
    start = (0.0, -RADIUS_M)  # on the path, at arc length 0
    points, tangents = path.reference_points(*start, v_ref, dt, horizon)
    # Analytic: the point at arc length s is at angle -pi/2 + s/R on the circle.
    angle = -np.pi / 2 + v_ref * dt * np.arange(1, horizon + 1) / RADIUS_M
    expected = RADIUS_M * np.column_stack([np.cos(angle), np.sin(angle)])
    assert np.max(np.hypot(*(points - expected).T)) < 1e-3
    # consecutive points are v_ref*dt apart along the curve (chord slightly shorter than the arc)
    chords = np.hypot(*np.diff(points, axis=0).T)
    assert np.allclose(chords, 2 * RADIUS_M * np.sin(v_ref * dt / (2 * RADIUS_M)), atol=1e-4)
    assert np.allclose(tangents, np.column_stack([-np.sin(angle), np.cos(angle)]), atol=1e-3)


def test_projection_from_off_the_curve_starts_at_the_closest_point():
    path = arc()
    # a point 2 m outside the circle at 30 degrees into the arc: closest point at s = R * pi/6
    angle = -np.pi / 2 + np.pi / 6
    x, y = (RADIUS_M + 2.0) * np.cos(angle), (RADIUS_M + 2.0) * np.sin(angle)
    assert path.project(x, y) == pytest.approx(RADIUS_M * np.pi / 6, abs=1e-3)
    # outside a left-turning curve is to the right of travel
    assert path.lateral_offset(x, y)[0] == pytest.approx(-2.0, abs=1e-3)
    assert path.length_m == pytest.approx(RADIUS_M * np.pi / 2, abs=1e-3)


def test_reference_points_stop_at_the_end_of_the_path():
    path = LanePath.straight((0, 0), (10, 0))
    points, _ = path.reference_points(8.0, 0.0, 15.0, 0.04, 10)
    assert points[-1].tolist() == [10.0, 0.0]


def test_parallel_lane_keeps_direction_and_offset():
    left = arc().parallel(3.5)
    assert left.lateral_offset(0.0, -RADIUS_M)[0] == pytest.approx(-3.5, abs=1e-2)
    assert left.length_m == pytest.approx((RADIUS_M - 3.5) * np.pi / 2, rel=1e-3)


@pytest.mark.parametrize(
    "coordinates, message",
    [([[0, 0]], "at least two distinct points"), ([[0, 0], [0, 0]], "at least two"), ([[0, 0], [np.nan, 1]], "finite")],
)
def test_bad_paths_are_rejected(coordinates, message):
    with pytest.raises(PathError, match=message):
        LanePath(coordinates)
