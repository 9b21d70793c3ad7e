"""The vehicles in the lanes beside the ego's that it may enter, for J0's lane-entry gap (:class:`LaneNeighbour`).

In each lane beside the ego's that it may enter (the lane J1 tracks, the lanes it passes a blockage in), the
nearest relevant vehicle whose centre is behind the ego's and the nearest whose centre is ahead: the two a plan that
enters the lane merges between. Not in the other lanes: a car holding its lane beside an ambulance's, with the gap
charged for every sample that strayed that way, drifted 1.6 m to the other side (MPPI's mean moves away from a
one-sided cost; the golden run `emergency_rescue_lane` hold). Each is predicted as J0's discs predict it (at
constant speed along its lane; a follower in a lane beside a blockage, yielding where it can: :func:`can_let_in`),
and the lane's centre line is sampled where the ego is predicted at its speed now, so that how deep a plan is in the
lane does not depend on how far along the curve the vehicle is.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from agentic_mpc.primitives import LaneNeighbour
from agentic_mpc.sumo.config import SurroundingsConfig
from agentic_mpc.sumo.kernels import disc_centres, side_lines
from agentic_mpc.sumo.network import Road
from agentic_mpc.world.observation import Observation, VehicleObservation


def lane_neighbours(
    observation: Observation,
    road: Road,
    steps_s: np.ndarray,
    ego_size_m: tuple[float, float],
    ego_lateral_m: float,
    relevant: Callable[[VehicleObservation], bool],
    lanes: frozenset[int],
    yielding_lanes: frozenset[int] = frozenset(),
    yield_mps: float = 0.0,
    lets_in: Callable[[VehicleObservation], bool] = lambda vehicle: True,
) -> tuple[LaneNeighbour, ...]:
    """The neighbours in ``lanes`` (those beside the ego's lane). ``ego_size_m``: its length and width;
    ``ego_lateral_m``: its centre's offset left of the road's reference line; ``relevant``: whether a vehicle can come
    near within the horizon; ``yielding_lanes``: lanes whose followers are predicted ``yield_mps`` slower where they
    can let the ego in (``lets_in``, as J0's discs)."""
    ego = observation.ego
    if not ego.lane_role or ego.lane_index is None:
        return ()
    length_m, width_m = ego_size_m
    bounds = road.lane_bounds_m
    neighbours: list[LaneNeighbour] = []
    for lane in (ego.lane_index - 1, ego.lane_index + 1):
        if lane not in lanes:
            continue
        in_lane = [v for v in observation.traffic if v.lane_index == lane and v.lane_s_m is not None and relevant(v)]
        behind = max((v for v in in_lane if v.offset_m < 0.0), key=lambda v: v.offset_m, default=None)
        ahead = min((v for v in in_lane if v.offset_m >= 0.0), key=lambda v: v.offset_m, default=None)
        chosen = [v for v in (behind, ahead) if v is not None]
        if not chosen:
            continue
        centre_m = 0.5 * (bounds[lane][0] + bounds[lane][1])
        line = side_lines(road.reference_table, ego.road_s_m, max(ego.speed_mps, 0.0), steps_s, centre_m, centre_m)
        reach_m = 0.5 * road.lane_widths_m[lane] + 0.5 * width_m
        for vehicle in chosen:
            speed = vehicle.speed_mps
            if lane in yielding_lanes and vehicle.relation == "behind" and lets_in(vehicle):
                speed = max(0.0, speed - yield_mps)
            row = np.array([(speed, vehicle.lane_s_m, vehicle.lateral_offset_m, 0.0, math.nan)])
            centres, tangents = disc_centres(road.lane_tables[lane], steps_s, row)
            neighbours.append(LaneNeighbour(
                centres[0], tangents[0], np.ascontiguousarray(line[0]), np.ascontiguousarray(line[2]), reach_m,
                0.5 * (vehicle.length_m + length_m), speed, reach_m - abs(ego_lateral_m - centre_m)))
    return tuple(neighbours)


def can_let_in(follower: VehicleObservation, ego_speed_mps: float, config: SurroundingsConfig) -> bool:
    """Whether ``follower`` (behind in a lane beside) can let the ego in, braking at ``follower_yield_mps2`` while the
    ego speeds up at ``follower_yield_merge_accel_mps2``: its closing speed^2 <= 2 x both x (its gap - d0). The 2 s
    horizon showed a car at 14 m/s 16 m back braking clear of the ego pulling out at 1 m/s; beyond it, it was not
    (seed 3612, a side swipe). Else it is predicted at its speed."""
    if config.follower_yield_merge_accel_mps2 is None:
        return True
    closing_mps = follower.speed_mps - ego_speed_mps
    braking_mps2 = config.follower_yield_mps2 + config.follower_yield_merge_accel_mps2  # both close the gap
    room_m = max(follower.gap_m - config.leader_standstill_gap_m, 0.0)
    return closing_mps <= 0.0 or closing_mps**2 <= 2.0 * braking_mps2 * room_m
