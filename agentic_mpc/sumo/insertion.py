"""Where on a lane full of traffic the ego can enter: the free gaps nearest to the requested spot
(:func:`free_spots`, pure), and the retries at them (:func:`insert_at_free_gap`, through the bridge).

In dense traffic after a warm-up the requested start can stay occupied for longer than any wait (a run
failed: "SUMO did not insert 'ego' ... within 250 steps"). SUMO inserts a vehicle only where it and its
follower can brake safely, so a gap must hold the ego, both minimum gaps and about a time headway of
distance on each side (Krauss at equal speeds needs about speed x tau, tau = 1 s).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from agentic_mpc.sumo.records import SumoError

if TYPE_CHECKING:
    from agentic_mpc.sumo.bridge import SumoBridge

INSERTION_HEADWAY_S = 1.5
"""Distance kept to the leader and asked of the follower, in seconds at their speed (SUMO's tau 1 s + margin:
at 1.25 s SUMO refused a follower at 15.4 m/s, at 1.65 s it accepted, measured)."""
BRAKING_MPS2 = 4.0
"""Assumed braking for the difference of braking distances between a faster and a slower vehicle."""
MARGIN_M = 2.0
"""The spot keeps this far inside the free part of a gap (traffic moves while SUMO inserts)."""
INSERT_ATTEMPTS = 20
"""Free gaps tried (nearest first) when the ego's requested spot stays occupied."""


def secure_gap_m(speed_mps: float, leader_speed_mps: float) -> float:
    """The gap SUMO wants before it inserts the ego behind a leader (Krauss: v tau + v^2 / 2b minus the
    leader's braking distance, plus the ego's minGap; the ego's tau 1 s, b 6 m/s^2; the cars' b 5 m/s^2)."""
    return max(0.0, speed_mps * 1.0 + speed_mps ** 2 / 12.0 - leader_speed_mps ** 2 / 10.0) + 2.5


def entry_speed_mps(gap_m: float, leader_speed_mps: float, speed_mps: float) -> float:
    """The fastest speed up to ``speed_mps`` (in 0.5 m/s steps) at which SUMO inserts the ego ``gap_m`` behind
    a leader at ``leader_speed_mps``, with a 10 % margin on the secure gap."""
    speed = speed_mps
    while speed > 0.0 and 1.1 * secure_gap_m(speed, leader_speed_mps) > gap_m:
        speed -= 0.5
    return max(speed, 0.0)


def speed_behind_leader(
    vehicles: Sequence[tuple[float, float, float, float]], pos_m: float, within_m: float, speed_mps: float
) -> float:
    """The ego's entry speed at front-bumper position ``pos_m`` of a lane whose ``vehicles`` are (front-bumper
    position, length, minGap, speed): with a vehicle ahead within ``within_m`` (bumper to bumper), that vehicle's
    speed (not above ``speed_mps``), lowered until SUMO accepts the gap; else ``speed_mps``. A scene predicts
    where traffic will be; SUMO's drivers may have braked meanwhile (LaMPilot's evaluator reads the leader)."""
    ahead = [(pos - length - pos_m, speed) for pos, length, _, speed in vehicles if pos - length > pos_m]
    if not ahead:
        return speed_mps
    gap_m, leader_speed = min(ahead)
    if gap_m > within_m:
        return speed_mps
    return entry_speed_mps(gap_m, leader_speed, min(speed_mps, leader_speed))


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


def insert_at_free_gap(
    bridge: SumoBridge,
    vehicle_id: str,
    route_id: str,
    type_id: str,
    *,
    lane_index: int,
    lane_id: str,
    lane_length_m: float,
    requested_pos_m: float,
    length_m: float,
    min_gap_m: float,
    speed_mps: float,
    fits: Callable[[float], bool],
    wait_steps: int,
) -> float:
    """Insert the externally driven ``vehicle_id`` at the free gap of ``lane_id`` nearest to the requested
    spot, after SUMO could not insert it there; returns the front-bumper position it got in at.

    The gaps are read anew before each attempt (traffic moves while SUMO tries); a spot within 2 m of one
    tried before, or where the vehicle would not be on the road (``fits``), is skipped; each attempt waits
    ``wait_steps`` steps. Raises :class:`SumoError` when no gap is left or :data:`INSERT_ATTEMPTS` failed.
    """
    tried: list[float] = []
    for _ in range(INSERT_ATTEMPTS):
        spots = free_spots(bridge.lane_vehicles(lane_id), lane_length_m, requested_pos_m, length_m, min_gap_m, speed_mps)
        pos = next((p for p in spots if all(abs(p - t) > 2.0 for t in tried) and fits(p)), None)
        if pos is None:
            break
        tried.append(pos)
        bridge.add_external_vehicle(vehicle_id, route_id, type_id, lane_index=lane_index, pos_m=pos,
                                    speed_mps=speed_mps, wait=False)
        if bridge.wait_until_inserted(vehicle_id, wait_steps, withdraw=True) is not None:
            return pos
    raise SumoError(
        f"SUMO did not insert {vehicle_id!r} on lane {lane_id} at {requested_pos_m} m nor at the free gaps"
        f" tried at {[round(t, 1) for t in tried]} m (t={bridge.time_s:.2f} s)"
    )
