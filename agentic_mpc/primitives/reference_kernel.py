"""J1's reference points in one compiled pass (the control step prepares them every 40 ms).

It computes what ``LanePath.project`` (shapely's ``line_locate_point``) followed by
``LanePath.points_and_tangents_at`` compute, to rounding, without creating a shapely point or a dozen
small NumPy arrays per step: those cost about 0.2 ms of a 1 ms control step on the project machine.
``tests/primitives/test_reference_kernel.py`` checks it against that readable definition.
"""

from __future__ import annotations

import numba
import numpy as np

from agentic_mpc.geometry import LanePath

# No fastmath: the projection compares distances and must pick the segment the reference picks.
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(**_JIT)
def _project(xy, s_vertex, x, y):
    """Arc length of the point of the polyline closest to (x, y); the first segment wins a tie."""
    best_d2 = np.inf
    best_s = 0.0
    for i in range(xy.shape[0] - 1):
        ax, ay = xy[i, 0], xy[i, 1]
        dx, dy = xy[i + 1, 0] - ax, xy[i + 1, 1] - ay
        t = ((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)
        t = min(max(t, 0.0), 1.0)
        ex, ey = ax + t * dx - x, ay + t * dy - y
        d2 = ex * ex + ey * ey
        if d2 < best_d2:
            best_d2 = d2
            best_s = s_vertex[i] + t * (s_vertex[i + 1] - s_vertex[i])
    return best_s


@numba.njit(**_JIT)
def _fill(xy, s_vertex, unit_tangents, x, y, v_now, v_ref, accel, dt, points, tangents):
    """Points k = 1..H from the projection of (x, y): spaced v_ref*dt (``accel`` <= 0, the paper's form) or
    along a speed ramp from ``v_now`` to ``v_ref`` at ``accel``; clamped to the path's ends."""
    start = _project(xy, s_vertex, x, y)
    last = s_vertex.shape[0] - 1
    change = v_ref - v_now
    sign = 1.0 if change > 0.0 else (-1.0 if change < 0.0 else 0.0)
    travelled = 0.0
    for k in range(points.shape[0]):
        if accel > 0.0:
            travelled += v_now + sign * min(abs(change), accel * (dt * (k + 1)))
            s = start + travelled * dt
        else:
            s = start + v_ref * dt * (k + 1)
        s = min(max(s, 0.0), s_vertex[last])
        i = min(max(np.searchsorted(s_vertex, s, side="right") - 1, 0), last - 1)
        along = s - s_vertex[i]
        points[k, 0] = xy[i, 0] + along * unit_tangents[i, 0]
        points[k, 1] = xy[i, 1] + along * unit_tangents[i, 1]
        tangents[k, 0] = unit_tangents[i, 0]
        tangents[k, 1] = unit_tangents[i, 1]


def reference_points(
    path: LanePath, x_m: float, y_m: float, v_now_mps: float, v_ref_mps: float, accel_mps2: float | None,
    dt_s: float, horizon: int,
) -> tuple[np.ndarray, np.ndarray]:
    """J1's reference: (points (H, 2), unit tangents (H, 2)); ``accel_mps2`` None is the paper's constant spacing."""
    points = np.empty((horizon, 2))
    tangents = np.empty((horizon, 2))
    xy, s_vertex, unit_tangents = path.arrays
    _fill(xy, s_vertex, unit_tangents, x_m, y_m, v_now_mps, v_ref_mps, accel_mps2 or 0.0, dt_s, points, tangents)
    return points, tangents


def reference_points_readable(
    path: LanePath, x_m: float, y_m: float, v_now_mps: float, v_ref_mps: float, accel_mps2: float | None,
    dt_s: float, horizon: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The same in NumPy and shapely, as the paper and ``PathTracking`` define it: what the kernel must equal."""
    if accel_mps2 is None:
        return path.reference_points(x_m, y_m, v_ref_mps, dt_s, horizon)
    elapsed = dt_s * np.arange(1, horizon + 1)
    change = v_ref_mps - v_now_mps
    speeds = v_now_mps + np.sign(change) * np.minimum(abs(change), accel_mps2 * elapsed)
    return path.points_and_tangents_at(path.project(x_m, y_m) + np.cumsum(speeds) * dt_s)
