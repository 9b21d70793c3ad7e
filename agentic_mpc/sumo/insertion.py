"""Where on a lane full of traffic the ego can enter: the free gaps nearest to the requested spot (pure).

In dense traffic after a warm-up the requested start can stay occupied for longer than any wait (a run
failed: "SUMO did not insert 'ego' ... within 250 steps"). SUMO inserts a vehicle only where it and its
follower can brake safely, so a gap must hold the ego, both minimum gaps and about a time headway of
distance on each side (Krauss at equal speeds needs about speed x tau, tau = 1 s).
"""

from __future__ import annotations

from collections.abc import Sequence

INSERTION_HEADWAY_S = 1.5
"""Distance kept to the leader and asked of the follower, in seconds at their speed (SUMO's tau 1 s + margin:
at 1.25 s SUMO refused a follower at 15.4 m/s, at 1.65 s it accepted, measured)."""
BRAKING_MPS2 = 4.0
"""Assumed braking for the difference of braking distances between a faster and a slower vehicle."""
MARGIN_M = 2.0
"""The spot keeps this far inside the free part of a gap (traffic moves while SUMO inserts)."""


def free_spots(
    vehicles: Sequence[tuple[float, float, float, float]],
    lane_length_m: float,
    requested_pos_m: float,
    ego_length_m: float,
    ego_min_gap_m: float,
    speed_mps: float,
    headway_s: float = INSERTION_HEADWAY_S,
) -> list[float]:
    """Front-bumper lane positions, one per free gap, nearest to ``requested_pos_m`` first.

    ``vehicles``: (front-bumper lane position, length, minGap, speed) of every vehicle on the lane. In each
    gap the spot is the requested position clamped into the part of the gap where the ego fits safely.
    """
    ordered = sorted(vehicles)
    spots: list[float] = []
    # Behind the first vehicle: bounded by the lane start (the ego's back stays on the lane).
    low_m = ego_length_m
    for pos, length, min_gap, speed in [*ordered, (None, 0.0, 0.0, 0.0)]:
        if pos is None:
            high_m = lane_length_m - 1.0  # ahead of the last vehicle: up to the lane's end
        else:
            # the ego keeps its minGap and a headway behind the leader's back, plus the difference of the two
            # braking distances if it is faster
            brake_m = max(0.0, speed_mps**2 - speed**2) / (2.0 * BRAKING_MPS2)
            high_m = pos - length - ego_min_gap_m - headway_s * speed_mps - brake_m - MARGIN_M
        if high_m >= low_m:
            spots.append(min(max(requested_pos_m, low_m), high_m))
        if pos is not None:
            # the follower (this vehicle) keeps its minGap and a headway at its speed behind the ego's back
            brake_m = max(0.0, speed**2 - speed_mps**2) / (2.0 * BRAKING_MPS2)
            low_m = max(low_m, pos + min_gap + headway_s * speed + brake_m + ego_length_m + MARGIN_M)
    return sorted(spots, key=lambda p: abs(p - requested_pos_m))
