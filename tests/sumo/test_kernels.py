"""The compiled surroundings geometry (agentic_mpc.polylines.kernels) gives the NumPy / Python results it replaces
to the last bit: goldens pin whole runs, these pin the kernels on the shipped roads, including the edges of
the lines, vertices, ties, far guesses and NaN."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agentic_mpc.polylines import kernels
from agentic_mpc.sumo.network import RoadNetwork
from agentic_mpc.sumo.scenarios import curvy_traffic_config, scenario2_config

STEPS = 0.04 * np.arange(1, 51)


def _lines():
    for config in (curvy_traffic_config(), scenario2_config(), curvy_traffic_config(lefthand=True)):
        road = RoadNetwork(config.net_file).road(config.road)
        yield from (road.reference_table, *road.lane_tables)


LINES = list(_lines())


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a), np.signbit(b))


def _arc_lengths(line, rng) -> np.ndarray:
    return np.concatenate([
        rng.uniform(-10.0, line.length_m + 10.0, 2000), line.s, np.nextafter(line.s, np.inf),
        np.nextafter(line.s, -np.inf), [np.nan, -np.inf, np.inf, 0.0, -0.0, line.length_m],
    ])


@pytest.mark.parametrize("line", LINES, ids=range(len(LINES)))
def test_points_at_is_polyline_at(line):
    s = _arc_lengths(line, np.random.default_rng(0))
    points, tangents = line.at(s)
    got_points, got_tangents = kernels.points_at(line, s)
    assert _same(got_points, points) and _same(got_tangents, tangents)


@pytest.mark.parametrize("line", LINES, ids=range(len(LINES)))
def test_locate_is_polyline_locate(line):
    rng = np.random.default_rng(1)
    s_true = np.concatenate([rng.uniform(-5.0, line.length_m + 5.0, 1000), line.s])
    points, tangents = line.at(s_true)
    offsets = rng.uniform(-6.0, 6.0, len(s_true))
    xs, ys = points[:, 0] - offsets * tangents[:, 1], points[:, 1] + offsets * tangents[:, 0]
    guesses = s_true + rng.choice([0.0, 1.0, -3.0, 10.0, -25.0, 80.0], len(s_true))
    for x, y, guess in zip(xs.tolist(), ys.tolist(), [*guesses.tolist()[:-3], math.nan, -math.inf, math.inf],
                           strict=True):
        expected = line.locate(x, y, guess)
        got = kernels.locate(line, x, y, guess)
        assert got == expected and [math.copysign(1.0, v) for v in got] == [math.copysign(1.0, v) for v in expected]


@pytest.mark.parametrize("line", LINES, ids=range(len(LINES)))
def test_disc_centres_are_the_numpy_sums(line):
    rng = np.random.default_rng(2)
    n = 40
    rows = np.column_stack([
        rng.uniform(0.0, 30.0, n), rng.uniform(-20.0, line.length_m + 20.0, n),
        rng.choice([0.0, 0.0, -0.7, 1.3, np.nan], n), rng.choice([0.0, -2.5, 1.1, 3.75], n),
        rng.choice([np.nan, 0.0, 0.7, -2.9], n),  # the vehicle's heading (NaN: along its lane)
    ])
    got, got_headings = kernels.disc_centres(line, STEPS, rows)
    for row, centres, headings in zip(rows.tolist(), got, got_headings, strict=True):
        speed, lane_s, lateral, offset, vehicle_heading = row
        expected, heading = line.at(lane_s + speed * STEPS)  # what the surroundings did one vehicle at a time
        if lateral:
            expected = expected + lateral * np.stack([-heading[:, 1], heading[:, 0]], axis=1)
        if not np.isnan(vehicle_heading):  # the lane's tangent turned by the vehicle's angle to it at lane_s
            _, (now,) = line.at(np.array([lane_s]))
            h = np.array([np.cos(vehicle_heading), np.sin(vehicle_heading)])
            cos_a, sin_a = now[0] * h[0] + now[1] * h[1], now[0] * h[1] - now[1] * h[0]
            heading = np.stack([heading[:, 0] * cos_a - heading[:, 1] * sin_a,
                                heading[:, 1] * cos_a + heading[:, 0] * sin_a], axis=1)
        if offset:
            expected = expected + offset * heading
        assert _same(centres, expected)
        assert _same(headings, heading)  # the vehicle's heading at the disc, for the ego-heading-aware radius


@pytest.mark.parametrize("line", LINES, ids=range(len(LINES)))
def test_side_lines_are_the_numpy_edges(line):
    for start, speed, left, right in ((10.0, 15.0, 5.25, -5.25), (line.length_m - 3.0, 22.0, 1.6, -1.9), (-4.0, 0.0, 0.0, -3.2)):
        points, tangents = line.at(start + speed * STEPS)
        normal = tangents[:, ::-1] * np.array([-1.0, 1.0])
        got = kernels.side_lines(line, start, speed, STEPS, left, right)
        assert _same(got[0], points + left * normal) and _same(got[1], points + right * normal)
        assert _same(got[2], tangents)
