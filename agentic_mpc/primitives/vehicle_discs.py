"""J0's clearance from other road users' discs, the NumPy reference (the fused kernel computes the same in
``controller/kernels.py``), and the kernel's row for each disc.

A stage inside a disc (``MovingDisc``) costs ``clearance`` x (2 - d²/r²): 1 x at its rim, 2 x at its centre; where
the two bodies touch (d inside ``contact_share`` of the bodies' radius; for two cars 0.8 x 2.4 m, their half widths,
the rest of the radius being the clearance margin) up to ``contact`` more, x (1 - d²/r_touch²), as far as the ego
closes in by its own motion (in full from ``closing_mps``): in the frame of the other's travel, its velocity relative
to the other's, across towards it (a lane change into it) and along onto one ahead (running into it); not the
other's cutting in or closing from behind.

Why the contact term: the margin is soft, touching is not. Squeezed in a crawling queue, every plan inside three
discs, the ego crept into the car ahead: a plan into its body cost at most twice one at its margin. Only the ego's
own motion: charged for a contact the other drives into, a standing ego fled (an ambulance squeezing past made it
throttle into the stopped car ahead). docs/traffic.md, "Touching is not the margin".
"""

from __future__ import annotations

import numpy as np

from agentic_mpc.primitives.base import FloatArray, MovingDisc, Rollouts


def disc_cost(disc: MovingDisc, r: Rollouts, dt_s: float, clearance: float, contact: float, contact_share: float,
              closing_mps: float) -> FloatArray:
    """The disc's cost of every plan, a stage mean; ``clearance`` and ``contact`` per stage."""
    h = r.x_m.shape[0]
    dx, dy = r.x_m - disc.centres[:, 0:1], r.y_m - disc.centres[:, 1:2]
    d2 = dx * dx + dy * dy
    bodies = _bodies_radius_m(disc, r)
    r2 = np.maximum(disc.radius_m, bodies) ** 2
    touch2 = contact_share**2 * bodies * bodies
    stage = np.where(d2 < r2, clearance * (2.0 - d2 / r2), 0.0)
    headings = _ALIGNED[h] if disc.headings is None else disc.headings
    hx, hy = headings[:, 0:1], headings[:, 1:2]
    stage += np.where(d2 < touch2, contact * (1.0 - d2 / touch2) * _closing(disc, r, dt_s, dx, dy, d2, hx, hy,
                                                                           closing_mps), 0.0)
    return np.sum(stage, axis=0) / h


def _closing(disc: MovingDisc, r: Rollouts, dt_s: float, dx: FloatArray, dy: FloatArray, d2: FloatArray,
             hx: FloatArray, hy: FloatArray, closing_mps: float) -> FloatArray:
    """How far (0-1) the ego closes in on the other by its own motion. In the frame of the other's travel (of its
    predicted centres, along its lane; standing, its heading), where the other does not move sideways: the ego's
    velocity relative to the other's, across towards it (a lane change into it), and along onto one ahead."""
    ahead = np.vstack((disc.centres[1:2], disc.centres[1:])) if len(disc.centres) > 1 else disc.centres
    behind = np.vstack((disc.centres[0:1], disc.centres[:-1]))
    v_other = (ahead - behind) / dt_s
    speed_other = np.sqrt(v_other[:, 0:1] ** 2 + v_other[:, 1:2] ** 2)
    moving = speed_other > 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(moving, v_other[:, 0:1] / speed_other, hx)
        ty = np.where(moving, v_other[:, 1:2] / speed_other, hy)
        wx = r.v_mps * np.cos(r.phi_rad) - v_other[:, 0:1]
        wy = r.v_mps * np.sin(r.phi_rad) - v_other[:, 1:2]
        d = np.sqrt(d2)
        along, across = -(dx * tx + dy * ty) / d, (dx * ty - dy * tx) / d
        towards = (wy * tx - wx * ty) * across + np.maximum(0.0, along) * (wx * tx + wy * ty)
        return np.where(d2 > 0.0, np.clip(towards / closing_mps, 0.0, 1.0), 1.0)


def disc_row(disc: MovingDisc, horizon: int, clearance: float, contact: float, contact_share: float,
             closing_mps: float) -> tuple:
    """The fused kernel's entry of one disc (``FusedTerms.discs``): the weights per stage / H."""
    if disc.headings is None:
        headings, extents = _ALIGNED[horizon], (0.0, 0.0)
    else:
        headings, extents = disc.headings, disc.ego_half_extents_m
    body = disc.radius_m if disc.body_radius_m is None else disc.body_radius_m
    return (disc.centres, headings, disc.radius_m, clearance / horizon, body, *extents, contact / horizon,
            contact_share**2, 1.0 / closing_mps)


def _bodies_radius_m(disc: MovingDisc, r: Rollouts) -> FloatArray | float:
    """The radius of the disc's part that is the two bodies (``MovingDisc.body_radius_m``) with the ego turned
    against the heading its cover assumes (``MovingDisc.headings``): its corner reaches ``a |sin psi| - b (1 -
    |cos psi|)`` further; written as the fused kernel writes it. The cover's radius is at least this."""
    half_length, half_width = disc.ego_half_extents_m
    body = disc.radius_m if disc.body_radius_m is None else disc.body_radius_m
    if disc.headings is None or (half_length == 0.0 and half_width == 0.0):
        return body
    hx, hy = disc.headings[:, 0:1], disc.headings[:, 1:2]
    c, s = np.cos(r.phi_rad), np.sin(r.phi_rad)
    cos_rel, sin_rel = c * hx + s * hy, s * hx - c * hy
    return body + np.maximum(0.0, half_length * np.abs(sin_rel) - half_width * (1.0 - np.abs(cos_rel)))


class _AlignedHeadings(dict):
    """(H, 2) rows of (1, 0) per horizon, made once: the fused kernel reads a heading for every disc, and a
    disc without one ignores it (its half extents are 0)."""

    def __missing__(self, horizon: int) -> FloatArray:
        value = self[horizon] = np.tile([1.0, 0.0], (horizon, 1))
        return value


_ALIGNED = _AlignedHeadings()
