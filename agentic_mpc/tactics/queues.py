"""Blockages, as the tactics see them: a static obstacle and the vehicles standing nose to tail behind it in its
lane (a queue). Every rule of the layer reads them (:mod:`agentic_mpc.tactics.layer`); the world's surroundings
builder turns them into J0's queue room behind the last car (``Surroundings.blockages``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from agentic_mpc.primitives import Blockage
from agentic_mpc.world.observation import Observation, ObstacleObservation, VehicleObservation

QUEUE_STANDING_MPS = 0.5
"""A vehicle slower than this behind a blockage joins its queue."""
QUEUE_LINK_M = 12.0
"""... if its front bumper is at most this far behind the rear of the queue so far (SUMO queues at 2.5 m)."""
QUEUE_APPROACH_M = 50.0
"""A leader this close behind a queue's tail in its lane is about to stand in it: J0 keeps room behind it."""
QUEUE_LEADER_WITHIN_M = 4.0
"""A queue member this close ahead in the ego's own lane stays a leader of J0's time gap: from there the ego
cannot pull out, and without the gap term it crept into the car while trying (measured: ego_into_stopped at
0.5 m/s). In the lane beside, it is not (beside a queue the gap along the tracked lane held the ego still)."""


@dataclass(frozen=True, slots=True)
class Queue:
    """A static obstacle and the vehicles standing nose to tail behind it in its lane (``members``, nearest
    the obstacle first): they block the lane together. The members are not leaders of J0's time gap (that
    would hold the ego behind them for ever, along its path); J0 keeps room to pull out behind ``tail``."""

    obstacle_id: str
    lane_index: int
    members: tuple[str, ...]
    tail: Blockage
    tail_gap_m: float
    tail_rear_s_m: float = 0.0
    """Road coordinate of the rear of the queue's last car (or of the obstacle)."""
    nose_to_tail: bool = False
    """The ego stands in the queue's lane within ``QUEUE_LEADER_WITHIN_M`` of its last car."""


def find_queues(observation: Observation, cover_of: Callable[[VehicleObservation], Any],
                obstacle_cover: Callable[[ObstacleObservation], Any], range_ahead_m: float) -> tuple[Queue, ...]:
    """Each static obstacle ahead within ``range_ahead_m``, with the vehicles standing nose to tail behind it
    in its lane; ``cover_of`` / ``obstacle_cover`` give the disc cover (offsets along the heading, radius) the
    ego's centre must avoid around a vehicle / an obstacle. None when the ego is off the road's lanes."""
    ego = observation.ego
    if not ego.lane_role:
        return ()
    queues = []
    for obstacle in observation.obstacles:
        if obstacle.relation != "ahead" or obstacle.offset_m > range_ahead_m:
            continue
        standing = sorted(
            (v for v in observation.traffic
             if v.lane_index == obstacle.lane_index and v.lane_s_m is not None and v.relation == "ahead"
             and v.speed_mps < QUEUE_STANDING_MPS and v.road_s_m < obstacle.road_s_m),
            key=lambda v: -v.road_s_m,
        )
        rear_s = obstacle.road_s_m - 0.5 * obstacle.length_m
        members: list[VehicleObservation] = []
        for vehicle in standing:
            if rear_s - (vehicle.road_s_m + 0.5 * vehicle.length_m) > QUEUE_LINK_M:
                break
            members.append(vehicle)
            rear_s = vehicle.road_s_m - 0.5 * vehicle.length_m
        offset = 0.0
        if members:  # the band is its lane's: a car aligned to the side of its lane (a rescue lane) must
            # not put the ego beside it in the next lane "in line" with the queue; how far aside the ego is
            # counts from the car itself (``offset``)
            tail = members[-1]
            cover, gap, heading, offset = cover_of(tail), tail.gap_m, tail.heading_rad, tail.lateral_offset_m
            x = tail.x_m + offset * math.sin(heading)
            y = tail.y_m - offset * math.cos(heading)
        else:
            cover = obstacle_cover(obstacle)
            gap, x, y, heading = obstacle.gap_m, obstacle.x_m, obstacle.y_m, obstacle.heading_rad
        tx, ty = math.cos(heading), math.sin(heading)
        rear = cover.offsets_m[0]
        tail_disc = Blockage(x + rear * tx, y + rear * ty, tx, ty, cover.radius_m, offset)
        nose_to_tail = bool(members) and members[-1].relative_lane == 0 and gap <= QUEUE_LEADER_WITHIN_M
        queues.append(Queue(obstacle.id, obstacle.lane_index, tuple(v.id for v in members), tail_disc, gap,
                            rear_s, nose_to_tail))
    return tuple(queues)


def drives_up_to_a_queue(queues: tuple[Queue, ...], vehicle: VehicleObservation) -> bool:
    """Whether ``vehicle``'s front is within ``QUEUE_APPROACH_M`` behind a queue's tail in its lane."""
    front_s = vehicle.road_s_m + 0.5 * vehicle.length_m
    return any(q.lane_index == vehicle.lane_index and 0.0 <= q.tail_rear_s_m - front_s <= QUEUE_APPROACH_M
               for q in queues)
