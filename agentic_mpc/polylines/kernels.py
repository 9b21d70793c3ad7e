"""Compiled (Numba) per-step geometry of the controller's surroundings: points on the lane and road lines.

Why compiled: the surroundings are built every control step from a few vehicles and a 50-stage horizon,
where NumPy's per-call overhead dominates, and right after SUMO's step (and the controller's kernel) every
call runs with cold caches: measured in the co-simulation loop, about 6 us per NumPy call, 25-30 calls for
the discs alone. One compiled call does the same work.

Same results to the last bit as the NumPy they replace (:meth:`~agentic_mpc.polylines.polyline.Polyline.at` and the
sums of :mod:`~agentic_mpc.sumo.surroundings`): the same operations in the same order, each rounded (Numba
without ``fastmath`` neither fuses a multiply and an add nor reorders), the clamp and the segment search as
NumPy's (``tests/sumo/test_kernels.py`` compares them). :func:`body_disc_centres` replaces no NumPy: its behaviour
is pinned by ``tests/sumo/test_route_prediction.py``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from agentic_mpc.polylines.polyline import Polyline

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(**_JIT)
def _clamped(s: float, length: float) -> float:
    # np.minimum(np.maximum(s, 0.0), length) as NumPy's vectorised loops do it: NaN stays NaN, and -0.0 becomes
    # +0.0 (SIMD max returns its second operand on a tie). Explicit tests, not min/max: their NaN and tie rules
    # are what must match.
    if not s > 0.0 and not math.isnan(s):
        s = 0.0
    if s > length:  # noqa: PLR1730
        s = length
    return s


@numba.njit(**_JIT)
def _segment(inner_s: np.ndarray, s: float) -> int:
    # inner_s.searchsorted(s, side="right"): the count of inner vertices <= s; NaN sorts last, as in NumPy.
    lo, hi = 0, inner_s.shape[0]
    while lo < hi:
        mid = (lo + hi) >> 1
        if inner_s[mid] <= s or math.isnan(s):
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(**_JIT)
def _point(xy, s_table, tangents, inner_s, length, s):  # type: ignore[no-untyped-def]
    # Polyline.at for one arc length: (x, y, tx, ty) of the point at s, clamped to the line.
    v = _clamped(s, length)
    i = _segment(inner_s, v)
    d = v - s_table[i]
    tx, ty = tangents[i, 0], tangents[i, 1]
    return xy[i, 0] + d * tx, xy[i, 1] + d * ty, tx, ty


@numba.njit(**_JIT)
def _points(xy, s_table, tangents, inner_s, length, s, points, tangents_out):  # type: ignore[no-untyped-def]
    for k in range(s.shape[0]):
        points[k, 0], points[k, 1], tangents_out[k, 0], tangents_out[k, 1] = _point(
            xy, s_table, tangents, inner_s, length, s[k])


@numba.njit(**_JIT)
def _discs(xy, s_table, tangents, inner_s, length, steps, rows, out, headings):  # type: ignore[no-untyped-def]
    for n in range(rows.shape[0]):
        speed, lane_s, lateral, offset, heading = rows[n, 0], rows[n, 1], rows[n, 2], rows[n, 3], rows[n, 4]
        turned = not math.isnan(heading)
        cos_a, sin_a = 1.0, 0.0
        if turned:  # the vehicle's angle to its lane now, kept over the horizon
            _, _, t0x, t0y = _point(xy, s_table, tangents, inner_s, length, lane_s)
            ch, sh = math.cos(heading), math.sin(heading)
            cos_a = t0x * ch + t0y * sh
            sin_a = t0x * sh - t0y * ch
        for k in range(steps.shape[0]):
            x, y, tx, ty = _point(xy, s_table, tangents, inner_s, length, lane_s + speed * steps[k])
            if lateral != 0.0:  # off the lane's centre line: along the normal (-ty, tx)
                x = x + lateral * -ty
                y = y + lateral * tx
            hx, hy = tx, ty
            if turned:  # the lane's direction turned by the vehicle's angle to it
                hx = tx * cos_a - ty * sin_a
                hy = ty * cos_a + tx * sin_a
            if offset != 0.0:  # along the vehicle's heading
                x = x + offset * hx
                y = y + offset * hy
            out[n, k, 0] = x
            out[n, k, 1] = y
            headings[n, k, 0] = hx
            headings[n, k, 1] = hy


@numba.njit(**_JIT)
def _chord(xy, s_table, tangents, inner_s, length, front_s, lateral, body, rear_s_now, rear_x, rear_y):  # type: ignore[no-untyped-def]
    # The body's centre and heading with its front at front_s: the rear ``body`` behind on the line (before the
    # line's start, on the straight from where it is now to that start), the heading from rear to front.
    fx, fy, tx, ty = _point(xy, s_table, tangents, inner_s, length, front_s)
    fx = fx + lateral * -ty
    fy = fy + lateral * tx
    rear_s = front_s - body
    if rear_s >= 0.0 or not rear_s_now < 0.0:
        bx, by, ux, uy = _point(xy, s_table, tangents, inner_s, length, rear_s)
        bx = bx + lateral * -uy
        by = by + lateral * ux
    else:
        start_x, start_y, _, _ = _point(xy, s_table, tangents, inner_s, length, 0.0)
        f = rear_s / rear_s_now
        bx = start_x + (rear_x - start_x) * f
        by = start_y + (rear_y - start_y) * f
    hx, hy = fx - bx, fy - by
    d = math.sqrt(hx * hx + hy * hy)
    if d > 1e-9:
        hx, hy = hx / d, hy / d
    else:
        hx, hy = tx, ty
    return fx - 0.5 * body * hx, fy - 0.5 * body * hy, hx, hy


@numba.njit(**_JIT)
def _bodies(xy, s_table, tangents, inner_s, length, steps, rows, out, headings):  # type: ignore[no-untyped-def]
    for n in range(rows.shape[0]):
        speed, front_s, lateral, offset, body = rows[n, 0], rows[n, 1], rows[n, 2], rows[n, 3], rows[n, 4]
        x_now, y_now, heading_now, accel = rows[n, 5], rows[n, 6], rows[n, 7], rows[n, 8]
        # braking: it stops where it would at this deceleration (a car slowing to its waiting point stays there)
        standing_from_s = speed / -accel if accel < 0.0 else math.inf
        ch, sh = math.cos(heading_now), math.sin(heading_now)
        rear_x, rear_y = x_now - 0.5 * body * ch, y_now - 0.5 * body * sh
        rear_s_now = front_s - body
        # The pose now from the line and as seen: the difference is faded out over the first body length driven
        x0, y0, h0x, h0y = _chord(xy, s_table, tangents, inner_s, length, front_s, lateral, body, rear_s_now,
                                  rear_x, rear_y)
        dx, dy = x_now - x0, y_now - y0
        turn = math.atan2(h0x * sh - h0y * ch, h0x * ch + h0y * sh)
        for k in range(steps.shape[0]):
            t = min(steps[k], standing_from_s)
            driven = speed * t + 0.5 * accel * t * t if accel < 0.0 else speed * t
            x, y, hx, hy = _chord(xy, s_table, tangents, inner_s, length, front_s + driven, lateral, body,
                                  rear_s_now, rear_x, rear_y)
            w = 1.0 - driven / body if body > 0.0 else 0.0
            if w > 0.0:
                x, y = x + w * dx, y + w * dy
                c, s = math.cos(w * turn), math.sin(w * turn)
                hx, hy = hx * c - hy * s, hy * c + hx * s
            out[n, k, 0] = x + offset * hx
            out[n, k, 1] = y + offset * hy
            headings[n, k, 0] = hx
            headings[n, k, 1] = hy


@numba.njit(**_JIT)
def _sides(xy, s_table, tangents, inner_s, length, start, step, steps, left, right, out):  # type: ignore[no-untyped-def]
    for k in range(steps.shape[0]):
        x, y, tx, ty = _point(xy, s_table, tangents, inner_s, length, start + step * steps[k])
        out[0, k, 0] = x + left * -ty
        out[0, k, 1] = y + left * tx
        out[1, k, 0] = x + right * -ty
        out[1, k, 1] = y + right * tx
        out[2, k, 0] = tx
        out[2, k, 1] = ty


@numba.njit(**_JIT)
def _locate(xy, s_table, tangents, x, y, guess, window):  # type: ignore[no-untyped-def]
    # Polyline.locate step for step: its Python min/max (the first argument wins ties and NaN), its search.
    n = s_table.shape[0] - 1
    lo, hi = 0, s_table.shape[0]  # bisect.bisect_right(s, guess)
    while lo < hi:
        mid = (lo + hi) >> 1
        if guess < s_table[mid]:
            hi = mid
        else:
            lo = mid + 1
    i = min(max(lo - 1, 0), s_table.shape[0] - 2)
    lo, hi = max(0, i - window), min(n, i + window + 1)
    while True:
        best_d2, best_s, best_lateral, best_i = np.inf, 0.0, 0.0, lo
        for j in range(lo, hi):
            dx, dy = x - xy[j, 0], y - xy[j, 1]
            tx, ty = tangents[j, 0], tangents[j, 1]
            along = dx * tx + dy * ty
            if 0.0 > along:  # noqa: PLR1730 (Python's max(along, 0.0): the first argument wins ties and NaN)
                along = 0.0
            length = s_table[j + 1] - s_table[j]
            if length < along:  # noqa: PLR1730 (min(along, length), likewise)
                along = length
            ex, ey = dx - along * tx, dy - along * ty
            d2 = ex * ex + ey * ey
            if d2 < best_d2:
                best_d2, best_s, best_lateral, best_i = d2, s_table[j] + along, tx * dy - ty * dx, j
        if best_i == lo and lo > 0:
            lo = max(0, lo - 2 * window)
        elif best_i == hi - 1 and hi < n:
            hi = min(n, hi + 2 * window)
        else:
            return best_s, best_lateral


def locate(line: Polyline, x_m: float, y_m: float, s_guess_m: float, window: int = 3) -> tuple[float, float]:
    """``line.locate(x_m, y_m, s_guess_m)``: (arc length of the closest point, signed lateral offset)."""
    s, lateral = _locate(line.xy, line.s, line.tangents, float(x_m), float(y_m), float(s_guess_m), window)
    return s, lateral


def points_at(line: Polyline, s_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``line.at(s_m)`` for a 1-D array: points and unit tangents (n, 2)."""
    s = np.ascontiguousarray(s_m, dtype=np.float64)
    points, tangents = np.empty((s.shape[0], 2)), np.empty((s.shape[0], 2))
    _points(line.xy, line.s, line.tangents, line.inner_s, line.length_m, s, points, tangents)
    return points, tangents


def disc_centres(line: Polyline, steps: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (discs, H, 2) of discs around vehicles on ``line``, one row of ``rows`` each: (speed, lane_s,
    lateral offset, offset along the heading, the vehicle's heading in rad or NaN), and the vehicle's heading at
    each stage (discs, H, 2). Stage k: the lane point at ``lane_s + speed * steps[k]``, plus the lateral offset
    along the lane's normal (if non-zero), plus the offset along the heading: the lane's tangent there turned by
    the vehicle's angle to its lane at ``lane_s`` (NaN: not turned, the lane's tangent)."""
    out, headings = np.empty((rows.shape[0], steps.shape[0], 2)), np.empty((rows.shape[0], steps.shape[0], 2))
    _discs(line.xy, line.s, line.tangents, line.inner_s, line.length_m, steps, rows, out, headings)
    return out, headings


def body_disc_centres(line: Polyline, steps: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (discs, H, 2) and headings (discs, H, 2) of discs around vehicles whose front drives along ``line``
    as SUMO moves them, one row of ``rows`` each: (speed, the front's arc length, its lateral offset, the disc's
    offset along the heading from the centre, the body's length, the centre's x and y and the heading now, the
    acceleration). Stage k: the front at ``front_s`` plus the way driven by ``steps[k]`` at that speed (braking, at
    that deceleration until it stands: a car slowing for its waiting point stops there), the rear a body length behind it on the line (before the
    line's start: on the straight from where it is now), the heading from rear to front, the centre half a length
    behind the front; plus the difference between that pose and the one seen now, faded out over the first body
    length driven (a standing vehicle stays exactly where it is). SUMO turns a vehicle about so (its angle is from
    its back to its front position): on a tight turn the body cuts the corner, which discs along the lane's
    tangent missed by a metre in a U-turn."""
    out, headings = np.empty((rows.shape[0], steps.shape[0], 2)), np.empty((rows.shape[0], steps.shape[0], 2))
    _bodies(line.xy, line.s, line.tangents, line.inner_s, line.length_m, steps, rows, out, headings)
    return out, headings


def side_lines(line: Polyline, start_m: float, speed_mps: float, steps: np.ndarray, left_m: float, right_m: float
               ) -> np.ndarray:
    """(3, H, 2): the points ``left_m`` and ``right_m`` to the left of ``line`` (along its normal) at the arc
    lengths ``start_m + speed_mps * steps[k]``, and the line's unit tangents there."""
    out = np.empty((3, steps.shape[0], 2))
    _sides(line.xy, line.s, line.tangents, line.inner_s, line.length_m, start_m, speed_mps, steps, left_m, right_m,
           out)
    return out
