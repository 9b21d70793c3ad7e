"""The fast path: one fused Numba kernel that rolls out every sample and scores it.

It computes exactly what the NumPy reference computes (``rollout.py`` + each primitive's ``cost``) for
the built-in primitives, but without materialising (H, S) arrays and without transcendental calls in the
hot loop (measured 4-10x faster, see benchmarks/README.md):

- the horizon loop is outside and the sample loop inside, over contiguous per-sample state vectors, so
  the compiler vectorises it;
- tan(r_delta * delta) uses its Taylor series: |r_delta * delta| <= 0.1306 after steering saturation,
  where seven terms are exact to 1e-16 (a model that steers further, up to 0.8 rad, uses sin/cos series);
- the heading is carried as (cos phi, sin phi) and rotated by the small heading increment each step
  (series exact to 1e-15 for |dphi| <= 0.1 rad, i.e. speeds up to about 80 m/s), with a first-order
  renormalisation so it stays a unit vector at any speed;
- of the fast-math flags only ``contract`` (a multiply and an add fused into one FMA): it is what made the
  kernel fast (without it 1.2x slower; with it 1.05x of full fast-math, benchmarks/bench_versus_commit.py),
  and an FMA rounds the same on every CPU that has one. Reassociation, approximate functions and
  reciprocals could round differently per instruction set, so none is allowed (docs/reproducibility.md).
"""

from __future__ import annotations

import numba
import numpy as np

from agentic_mpc.primitives.base import FusedArrays
from agentic_mpc.primitives.mandatory import QUEUE_ROOM_KNEE_M as _ROOM_KNEE
from agentic_mpc.vehicle import STEER_LIMIT, VehicleParams

_JIT = {"fastmath": {"contract"}, "error_model": "numpy", "cache": True, "nogil": True}  # why: the docstring


SMALL_STEER_RAD = 0.1306
"""Up to this road-wheel angle (the paper's model at full lock) tan uses the short series; beyond, up to
:data:`MAX_STEER_RAD` (a car that turns at junctions), the ratio of the sine and cosine series."""
MAX_STEER_RAD = 0.8


def pack_params(params: VehicleParams) -> np.ndarray:
    """The model parameters in the order the kernel reads them (the last: 1 if the short tan series is exact)."""
    wheel_rad = abs(params.r_delta) * STEER_LIMIT
    if wheel_rad > MAX_STEER_RAD:
        raise ValueError(f"r_delta x the steering limit = {wheel_rad:.3f} rad: the fast path handles up to "
                         f"{MAX_STEER_RAD} rad of road-wheel angle")
    return np.array(
        [params.dt_s, params.r_delta, params.slip_gain, 1.0 / params.l_r_m, params.w_a, params.w_b, params.w_v,
         1.0 if wheel_rad <= SMALL_STEER_RAD + 1e-12 else 0.0]
    )


@numba.njit(**_JIT)
def _tan_small(u: float) -> float:
    u2 = u * u
    return u * (
        1.0
        + u2
        * (
            1.0 / 3.0
            + u2
            * (
                2.0 / 15.0
                + u2 * (17.0 / 315.0 + u2 * (62.0 / 2835.0 + u2 * (1382.0 / 155925.0 + u2 * (21844.0 / 6081075.0))))
            )
        )
    )


@numba.njit(**_JIT)
def _tan_moderate(u: float) -> float:
    """tan(u) for |u| <= 0.8 as sin/cos from their series (the last terms below 1e-17 there): plain arithmetic,
    so it rounds alike on every CPU, unlike libm's tan."""
    u2 = u * u
    sin_u = u * (1.0 - u2 / 6.0 * (1.0 - u2 / 20.0 * (1.0 - u2 / 42.0 * (1.0 - u2 / 72.0 * (1.0 - u2 / 110.0 * (
        1.0 - u2 / 156.0 * (1.0 - u2 / 210.0 * (1.0 - u2 / 272.0))))))))
    cos_u = 1.0 - u2 / 2.0 * (1.0 - u2 / 12.0 * (1.0 - u2 / 30.0 * (1.0 - u2 / 56.0 * (1.0 - u2 / 90.0 * (
        1.0 - u2 / 132.0 * (1.0 - u2 / 182.0 * (1.0 - u2 / 240.0)))))))
    return sin_u / cos_u


@numba.njit(**_JIT)
def _cos_small(d: float) -> float:
    d2 = d * d
    return 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0 - d2 * (1.0 / 40320.0))))


@numba.njit(**_JIT)
def _sin_small(d: float) -> float:
    d2 = d * d
    return d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0 - d2 * (1.0 / 362880.0)))))


@numba.njit(inline="always", **_JIT)
def _body_radius(body, half_length, half_width, cos_phi, sin_phi, hx, hy):
    """The bodies' radius of a disc with the ego turned against the cover's heading: its corner reaches further
    (``MovingDisc.headings``); the cover's radius is at least this."""
    cos_rel = cos_phi * hx + sin_phi * hy
    sin_rel = sin_phi * hx - cos_phi * hy
    return body + max(0.0, half_length * abs(sin_rel) - half_width * (1.0 - abs(cos_rel)))


@numba.njit(inline="always", **_JIT)
def _contact(d2, bodies, touch_weight, touch_share2, inv_closing, dx, dy, wx, wy, tx, ty):
    """Where the bodies touch (inside ``touch_share2`` x their radius squared): up to ``touch_weight`` on top of
    the disc's clearance, as far as the ego closes in by its own motion: (wx, wy) its velocity relative to the
    other's, (tx, ty) the other's direction of travel (``Mandatory.vehicle_contact_weight``,
    ``primitives/vehicle_discs.py``). A pass of its own, only where a sample touches: in the clearance's loop the
    branch and the root stopped it vectorising (2.5x the disc pass)."""
    touch2 = touch_share2 * bodies * bodies
    if d2 >= touch2:
        return 0.0
    closing = 1.0
    if d2 > 0.0:
        d = np.sqrt(d2)
        along = -(dx * tx + dy * ty) / d  # > 0: the other ahead
        across = (dx * ty - dy * tx) / d
        towards = (wy * tx - wx * ty) * across + max(0.0, along) * (wx * tx + wy * ty)
        closing = min(1.0, max(0.0, towards * inv_closing))
    return touch_weight * (1.0 - d2 / touch2) * closing


@numba.njit(**_JIT)
def rollout_costs(
    state,
    params,
    basis,
    z_delta,
    z_ab,
    track_ref,
    track_tan,
    track_weight,
    circles,
    steer_sign,
    lateral_sign,
    lateral_ref,
    lateral_tan,
    limits,
    disc_centres,
    disc_headings,
    disc_params,
    edge_ref,
    edge_tan,
    edge_params,
    leader_points,
    leader_tan,
    leader_start,
    leader_standstill,
    time_gap,
    queue_rooms,
    lane_line_table,
    lane_line_offsets,
    lane_line_params,
    rims,
    work,
    costs,
):
    """Total cost of every sample into ``costs`` (S,). ``z_delta``, ``z_ab``: (2L+1, S); ``work``: (10, S)."""
    n_coef, n_samples = z_delta.shape
    horizon = basis.shape[1]
    dt, r_delta, kappa, inv_lr, w_a, w_b, w_v = (
        params[0], params[1], params[2], params[3], params[4], params[5], params[6]
    )
    small_steer = params[7] > 0.5
    steer_w, ab_w, v_max, speed_w = limits[0], limits[1], limits[2], limits[3]
    rate_w, previous_delta, previous_ab = limits[4], limits[5], limits[6]
    smooth_d_w, smooth_ab_w, brake_w = limits[7], limits[8], limits[9]
    x, y, c, s, v, dcmd, abcmd = work[0], work[1], work[2], work[3], work[4], work[5], work[6]
    dprev, abprev = work[7], work[8]  # the raw commands of the previous stage, for the smoothness terms
    cos0, sin0 = np.cos(state[2]), np.sin(state[2])
    for i in range(n_samples):
        x[i] = state[0]
        y[i] = state[1]
        c[i] = cos0
        s[i] = sin0
        v[i] = state[3]
        costs[i] = 0.0
    # Each pass below is a plain loop over samples so that it vectorises; terms are separate passes.
    for k in range(horizon):
        b0 = basis[0, k]
        for i in range(n_samples):
            dcmd[i] = b0 * z_delta[0, i]
            abcmd[i] = b0 * z_ab[0, i]
        for j in range(1, n_coef - 1, 2):  # rows in pairs: half the passes over dcmd/abcmd
            bj, bj1 = basis[j, k], basis[j + 1, k]
            for i in range(n_samples):
                dcmd[i] += bj * z_delta[j, i] + bj1 * z_delta[j + 1, i]
                abcmd[i] += bj * z_ab[j, i] + bj1 * z_ab[j + 1, i]
        if n_coef % 2 == 0:
            bj = basis[n_coef - 1, k]
            for i in range(n_samples):
                dcmd[i] += bj * z_delta[n_coef - 1, i]
                abcmd[i] += bj * z_ab[n_coef - 1, i]
        if k == 0:  # no stage before the first: its differences are zero
            for i in range(n_samples):
                dprev[i] = dcmd[i]
                abprev[i] = abcmd[i]
        for i in range(n_samples):
            dc = dcmd[i]
            abc = abcmd[i]
            step_d = dc - dprev[i]
            step_ab = abc - abprev[i]
            dprev[i] = dc
            abprev[i] = abc
            over_d = max(abs(dc) - 1.0, 0.0)
            over_ab = max(abs(abc) - 1.0, 0.0)
            delta = min(max(dc, -1.0), 1.0)
            throttle = min(max(abc, 0.0), 1.0)
            brake = -min(max(abc, -1.0), 0.0)
            # Dynamics: gamma from tan(gamma) = kappa * tan(r_delta * delta) without atan/tan/sin/cos.
            g = kappa * (_tan_small(r_delta * delta) if small_steer else _tan_moderate(r_delta * delta))
            cos_g = 1.0 / np.sqrt(1.0 + g * g)
            sin_g = g * cos_g
            ci = c[i]
            si = s[i]
            vi = v[i]
            xn = x[i] + dt * vi * (ci * cos_g - si * sin_g)
            yn = y[i] + dt * vi * (si * cos_g + ci * sin_g)
            d_phi = dt * vi * inv_lr * sin_g
            cd = _cos_small(d_phi)
            sd = _sin_small(d_phi)
            cn = ci * cd - si * sd
            sn = si * cd + ci * sd
            norm = 1.5 - 0.5 * (cn * cn + sn * sn)
            vn = max(0.0, vi + dt * (w_a * throttle + w_b * brake + w_v * vi))
            over_v = max(vn - v_max, 0.0)
            x[i] = xn
            y[i] = yn
            c[i] = cn * norm
            s[i] = sn * norm
            v[i] = vn
            dcmd[i] = delta  # the saturated steering, for the steering-sign term below
            costs[i] += steer_w * over_d * over_d + ab_w * over_ab * over_ab + speed_w * over_v * over_v
            costs[i] += smooth_d_w * step_d * step_d + smooth_ab_w * step_ab * step_ab + brake_w * brake * brake
        if k == 0:  # anti-chatter: the first input against the one applied at the previous step
            for i in range(n_samples):
                d_delta = dcmd[i] - previous_delta
                d_ab = min(max(abcmd[i], -1.0), 1.0) - previous_ab
                costs[i] += rate_w * (d_delta * d_delta + d_ab * d_ab)
        # Stage costs on the state after step k (the paper's k + 1).
        for p in range(steer_sign.shape[0]):
            sign, weight = steer_sign[p, 0], steer_sign[p, 1]
            for i in range(n_samples):
                m = min(0.0, sign * dcmd[i])
                costs[i] += weight * m * m
        for t in range(track_ref.shape[0]):
            rx, ry, weight, cross_weight = track_ref[t, k, 0], track_ref[t, k, 1], track_weight[t, 0], track_weight[t, 1]
            tx, ty = track_tan[t, k, 0], track_tan[t, k, 1]
            for i in range(n_samples):
                dx = x[i] - rx
                dy = y[i] - ry
                cross = tx * dy - ty * dx
                costs[i] += weight * (dx * dx + dy * dy) + cross_weight * cross * cross
        for o in range(circles.shape[0]):
            cx, cy, r2, weight = circles[o, 0], circles[o, 1], circles[o, 2], circles[o, 3]
            for i in range(n_samples):
                dx = x[i] - cx
                dy = y[i] - cy
                costs[i] += weight if dx * dx + dy * dy < r2 else 0.0
        for p in range(lateral_sign.shape[0]):
            sign, weight, dead_zone = lateral_sign[p, 0], lateral_sign[p, 1], lateral_sign[p, 2]
            rx, ry, tx, ty = lateral_ref[p, k, 0], lateral_ref[p, k, 1], lateral_tan[p, k, 0], lateral_tan[p, k, 1]
            for i in range(n_samples):
                m = min(0.0, sign * (tx * (y[i] - ry) - ty * (x[i] - rx)) + dead_zone)
                costs[i] += weight * m * m
        for o in range(disc_centres.shape[0]):
            cx, cy = disc_centres[o, k, 0], disc_centres[o, k, 1]
            hx, hy = disc_headings[o, k, 0], disc_headings[o, k, 1]
            radius, weight, body = disc_params[o, 0], disc_params[o, 1], disc_params[o, 2]
            half_length, half_width = disc_params[o, 3], disc_params[o, 4]
            touch_weight, touch_share2, inv_closing = disc_params[o, 5], disc_params[o, 6], disc_params[o, 7]
            touching = 0
            for i in range(n_samples):
                dx = x[i] - cx
                dy = y[i] - cy
                d2 = dx * dx + dy * dy
                bodies = _body_radius(body, half_length, half_width, c[i], s[i], hx, hy)
                r = max(radius, bodies)
                r2 = r * r
                costs[i] += weight * (2.0 - d2 / r2) if d2 < r2 else 0.0
                touching += 1 if d2 < touch_share2 * bodies * bodies else 0
            if touching > 0 and touch_weight > 0.0:
                # The other's velocity over this stage (the first stage's: to the next), and its lane's direction:
                # that of its predicted motion (along its lane), else its heading.
                k0 = k - 1 if k > 0 else 0
                k1 = k0 + 1 if horizon > 1 else 0
                vox = (disc_centres[o, k1, 0] - disc_centres[o, k0, 0]) / dt
                voy = (disc_centres[o, k1, 1] - disc_centres[o, k0, 1]) / dt
                speed_other = np.sqrt(vox * vox + voy * voy)
                tx, ty = (vox / speed_other, voy / speed_other) if speed_other > 0.0 else (hx, hy)
                for i in range(n_samples):
                    dx = x[i] - cx
                    dy = y[i] - cy
                    bodies = _body_radius(body, half_length, half_width, c[i], s[i], hx, hy)
                    contact = _contact(dx * dx + dy * dy, bodies, touch_weight, touch_share2, inv_closing, dx, dy,
                                       v[i] * c[i] - vox, v[i] * s[i] - voy, tx, ty)
                    costs[i] += contact
        for e in range(edge_ref.shape[0]):
            ex, ey, tx, ty = edge_ref[e, k, 0], edge_ref[e, k, 1], edge_tan[e, k, 0], edge_tan[e, k, 1]
            side, margin, weight = edge_params[e, 0], edge_params[e, 1], edge_params[e, 2]
            for i in range(n_samples):
                violation = max(0.0, margin + side * (tx * (y[i] - ey) - ty * (x[i] - ex)))
                costs[i] += weight * violation * violation
        gap_s, gap_w, knee = time_gap[0], time_gap[2], time_gap[3]
        for o in range(leader_points.shape[0]):  # J0's time gap: along the path to the contact point
            lx, ly, tx, ty = leader_points[o, k, 0], leader_points[o, k, 1], leader_tan[o, k, 0], leader_tan[o, k, 1]
            cap = leader_start[o] + time_gap[4] * (k + 1)  # the wanted gap grows from the gap now at most this fast
            d0 = leader_standstill[o]  # J0's standstill gap, or the room to pull out before a blockage
            for i in range(n_samples):
                shortfall = max(0.0, min(gap_s * v[i] + d0, cap) - (tx * (lx - x[i]) + ty * (ly - y[i])))
                costs[i] += gap_w * (knee * (2.0 * shortfall - knee) if shortfall > knee else shortfall * shortfall)
    for o in range(queue_rooms.shape[0]):  # J0's room to pull out behind a blockage, on the plan's last state
        cx, cy, tx, ty = queue_rooms[o, 0], queue_rooms[o, 1], queue_rooms[o, 2], queue_rooms[o, 3]
        radius, turn_radius, cos_g, sin_g = queue_rooms[o, 4], queue_rooms[o, 5], queue_rooms[o, 6], queue_rooms[o, 7]
        half_inv_decel, weight, offset = queue_rooms[o, 8], queue_rooms[o, 9], queue_rooms[o, 10]
        for i in range(n_samples):
            behind = tx * (cx - x[i]) + ty * (cy - y[i])
            beside = tx * (cy - y[i]) - ty * (cx - x[i])
            if behind > -radius and abs(beside) < radius:  # in line, not past the rear disc; aside: from the car
                cos_end = cos_g - (radius - min(abs(beside + offset), radius)) / turn_radius
                wanted = turn_radius * (np.sqrt(1.0 - cos_end * cos_end) - sin_g) + half_inv_decel * v[i] * v[i]
                shortfall = max(0.0, wanted - (behind - radius))
                huber = _ROOM_KNEE * (2.0 * shortfall - _ROOM_KNEE) if shortfall > _ROOM_KNEE else shortfall * shortfall
                costs[i] += weight * huber
    n_points = lane_line_table.shape[0]
    if n_points > 0 and lane_line_offsets.shape[0] > 0:  # J0: a plan that ends standing across a lane line
        spacing, weight, standing = lane_line_params[0], lane_line_params[1], lane_line_params[2]
        half_length, half_width = lane_line_params[3], lane_line_params[4]
        x0, y0, t0x, t0y = lane_line_table[0, 0], lane_line_table[0, 1], lane_line_table[0, 2], lane_line_table[0, 3]
        for i in range(n_samples):
            if v[i] < standing:
                along = t0x * (x[i] - x0) + t0y * (y[i] - y0)
                j = min(max(int(np.floor(along / spacing + 0.5)), 0), n_points - 1)
                px, py = lane_line_table[j, 0], lane_line_table[j, 1]
                tx, ty = lane_line_table[j, 2], lane_line_table[j, 3]
                lateral = tx * (y[i] - py) - ty * (x[i] - px)
                reach = half_width * abs(c[i] * tx + s[i] * ty) + half_length * abs(s[i] * tx - c[i] * ty)
                slow = 1.0 - v[i] / standing
                for b in range(lane_line_offsets.shape[0]):
                    overlap = reach - abs(lateral - lane_line_offsets[b])
                    if overlap > 0.0:
                        costs[i] += weight * slow * overlap * overlap
    for o in range(rims.shape[0]):  # J2: a plan that ends standing on the rim of a circle (or in it)
        cx, cy, outer, depth, weight, standing = rims[o, 0], rims[o, 1], rims[o, 2], rims[o, 3], rims[o, 4], rims[o, 5]
        for i in range(n_samples):
            if v[i] < standing:
                dx = x[i] - cx
                dy = y[i] - cy
                within = min(outer - np.sqrt(dx * dx + dy * dy), depth)
                if within > 0.0:
                    costs[i] += weight * (1.0 - v[i] / standing) * within * within


def fused_costs(
    state: np.ndarray,
    params_packed: np.ndarray,
    basis: np.ndarray,
    z_delta: np.ndarray,
    z_ab: np.ndarray,
    terms: FusedArrays,
    work: np.ndarray,
    costs: np.ndarray,
) -> np.ndarray:
    """Run the fused kernel on one step's terms; fills and returns ``costs``."""
    rollout_costs(state, params_packed, basis, z_delta, z_ab, *terms, work, costs)
    return costs
