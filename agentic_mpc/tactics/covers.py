"""The discs that cover another vehicle (or a stopped-car obstacle) for the controller: the region the ego's
centre must keep out of, from both cars' sizes and a margin."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agentic_mpc.primitives import Circle
from agentic_mpc.world.observation import ObstacleObservation


@dataclass(frozen=True, slots=True)
class DiscCover:
    """Discs covering the region the ego's centre must avoid around one vehicle."""

    offsets_m: tuple[float, ...]
    """Along the vehicle's heading from its centre."""
    radius_m: float
    spacing_m: float = 0.0
    """The largest disc spacing that still covers the rectangle's sides (for extending the row)."""


def disc_cover(
    length_m: float,
    width_m: float,
    ego_length_m: float,
    ego_width_m: float,
    margin_m: float = 0.5,
    max_discs: int = 8,
    min_half_width_m: float = 0.0,
) -> DiscCover:
    """Discs covering the rectangle the ego's centre must avoid around another vehicle's centre:
    half length (L + L_ego)/2, half width max((W + W_ego)/2, ``min_half_width_m``).

    Radius r = half width + margin. The end discs sit so that they reach the rectangle's corners, and the
    discs are close enough that the long sides are covered between them too; the margin is what makes
    that possible (with margin 0 the corners would need infinitely many discs).
    """
    half_w = max(0.5 * (width_m + ego_width_m), min_half_width_m)
    half_l = 0.5 * (length_m + ego_length_m)
    radius = half_w + margin_m
    if margin_m <= 0.0 or half_l <= radius:
        return DiscCover((0.0,), math.hypot(half_l, half_w) + margin_m)
    chord = math.sqrt(radius * radius - half_w * half_w)  # half the side length one disc covers at |lat| = half_w
    end = max(0.0, half_l - chord)
    count = min(max_discs, math.ceil(end / chord) + 1)
    if count == 1:
        return DiscCover((0.0,), radius, 2.0 * chord)
    return DiscCover(tuple(float(o) for o in np.linspace(-end, end, count)), radius, 2.0 * chord)


def obstacle_circles(
    obstacle: ObstacleObservation, ego_length_m: float, ego_width_m: float, margin_m: float = 0.5
) -> tuple[Circle, ...]:
    """J2 circles for a stopped-vehicle obstacle (the same cover as moving vehicles get in J0)."""
    cover = disc_cover(obstacle.length_m, obstacle.width_m, ego_length_m, ego_width_m, margin_m)
    c, s = math.cos(obstacle.heading_rad), math.sin(obstacle.heading_rad)
    return tuple(
        Circle(x_m=obstacle.x_m + o * c, y_m=obstacle.y_m + o * s, radius_m=cover.radius_m, label=obstacle.id)
        for o in cover.offsets_m
    )
