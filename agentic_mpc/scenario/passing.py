"""How a run went past an obstacle: the side, the clearance and how soon the car was back in its lane."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import Circle


@dataclass(frozen=True)
class PassResult:
    side: Literal["left", "right", "hit"]
    min_clearance_m: float
    """Smallest distance of the ego's centre from the obstacle's boundary (negative: it entered)."""
    recovery_s: float
    """Time after passing until the ego is back within the lane tolerance of its lane and the speed tolerance
    of v_ref and stays there for the smoothing window (both as moving averages: MPPI leaves a speed ripple)."""


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Centred moving average with the window shrinking at the ends."""
    if window <= 1:
        return values
    kernel = np.ones(window)
    return np.convolve(values, kernel, "same") / np.convolve(np.ones_like(values), kernel, "same")


def analyse_pass(states: np.ndarray, dt_s: float, obstacle: Circle, lane: LanePath, v_ref_mps: float,
                 lane_tolerance_m: float = 0.5, speed_tolerance_mps: float = 1.0,
                 smoothing_s: float = 1.0) -> PassResult:
    """``states``: the ego's [x, y, phi, v] at every step (N, 4); ``lane``: the lane it should return to."""
    x, y, v = states[:, 0], states[:, 1], states[:, 3]
    distance = np.hypot(x - obstacle.x_m, y - obstacle.y_m) - obstacle.radius_m
    min_clearance = float(distance.min())
    passing = int(np.argmax(x >= obstacle.x_m)) if np.any(x >= obstacle.x_m) else len(x) - 1
    lateral = lane.lateral_offset(x, y)
    if min_clearance < 0.0:
        side: Literal["left", "right", "hit"] = "hit"
    else:
        side = "left" if lateral[passing] > 0 else "right"
    window = max(1, round(smoothing_s / dt_s))
    settled = (np.abs(moving_average(lateral, window)) <= lane_tolerance_m) & (
        np.abs(moving_average(v, window) - v_ref_mps) <= speed_tolerance_mps
    )
    after = settled[passing:]
    # back means back for at least the smoothing window, not a crossing
    sustained = np.array([after[i : i + window].all() and i + window <= len(after) for i in range(len(after))])
    recovery = float(np.argmax(sustained)) * dt_s if sustained.any() else float("inf")
    return PassResult(side, min_clearance, recovery)
