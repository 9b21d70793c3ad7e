"""Blockages: a static obstacle and the vehicles standing nose to tail behind it in its lane.

The SUMO surroundings (:mod:`agentic_mpc.sumo.surroundings`) turn each into J0's queue room behind its last car
(``Surroundings.blockages``), keep its cars out of J0's time gap unless the ego is nose to tail with one, give
a leader driving up to it the pull-out room as its standstill gap, and open the lanes beside it to the
corridor (docs/traffic.md, "An incident in traffic: what changed"); :class:`Detour` keeps J1 on the lane the
ego passes a queue in.
"""

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


APPROACH_CRAWL_MPS = 2.0
"""J1's reference coming up to a queue slows to no less than this (nor does its ramp start lower,
``PathTracking.reference_start_mps``): the last metres, and the stop, are J0's queue room."""


def approach_speed_cap_mps(queues: tuple[Queue, ...], lane_index: int, decel_mps2: float,
                           pull_out_room_m: Callable[[float], float]) -> float | None:
    """The speed from which braking at ``decel_mps2`` stops the ego ``pull_out_room_m(aside)`` behind the
    nearest queue with cars in it in ``lane_index`` (aside: its tail's cover radius), at least
    ``APPROACH_CRAWL_MPS``; None without such a queue. A lone stopped car is left to J2, as in the paper."""
    gaps = [(q.tail_gap_m, q.tail.radius_m) for q in queues if q.lane_index == lane_index and q.members]
    if not gaps:
        return None
    gap_m, aside_m = min(gaps)
    room_m = pull_out_room_m(aside_m)
    if not math.isfinite(room_m):
        return APPROACH_CRAWL_MPS
    return max(APPROACH_CRAWL_MPS, math.sqrt(2.0 * decel_mps2 * max(0.0, gap_m - room_m)))


def drives_up_to_a_queue(queues: tuple[Queue, ...], vehicle: VehicleObservation) -> bool:
    """Whether ``vehicle``'s front is within ``QUEUE_APPROACH_M`` behind a queue's tail in its lane."""
    front_s = vehicle.road_s_m + 0.5 * vehicle.length_m
    return any(q.lane_index == vehicle.lane_index and 0.0 <= q.tail_rear_s_m - front_s <= QUEUE_APPROACH_M
               for q in queues)


BESIDE_LONE_OBSTACLE_FROM_M = 20.0
"""In the lane beside a lone stopped obstacle at least this far ahead (from the ego's front to its rear), the ego
passes it in that lane. J2's swerve round a lone obstacle, as in the paper, takes the ego's centre over the lane
line 6-9 m before it (the goldens); further back the ego is in that lane for its own reasons (after a yield)."""

BESIDE_STANDING_MPS = 1.0
"""Slower than this in the lane beside a lone stopped obstacle, nearer than ``BESIDE_LONE_OBSTACLE_FROM_M`` too, the
ego passes it in that lane: it stands there for its own reasons (a yield), not in J2's swerve. J1 on the obstacle's
lane pulled it across the line 13-17 m behind the obstacle: it stood there 27 s, or swerved back in front of the
car behind it (seeds 3003, 3012)."""

PULL_OUT_ASIDE_M = 0.25
"""Standing behind a lone stopped obstacle, the ego has started to pull out to the side its centre is this far to."""

MERGE_GAP_M = 2.0
"""Driving towards a queue, J1 takes the lane beside only with this much room (bumper to bumper) to the cars in it
ahead of the ego and behind it (:func:`room_to_merge`) ..."""
MERGE_TIME_GAP_S = 0.5
"""... behind it, this much more of the follower's speed ..."""
MERGE_FOLLOWER_DECEL_MPS2 = 2.0
"""... and the distance in which the follower, braking this hard, comes down to the ego's speed."""
MERGE_WAIT_DECEL_MPS2 = 2.0
"""While the merge waits for room, J1's reference slows so that braking this hard stops the ego with room to pull
out behind the queue (:func:`approach_speed_cap_mps`): waiting at 15 m/s, the ego reached the queue too fast to
stop and swerved into the car it waited for (4459)."""


def room_to_merge(observation: Observation, lane_index: int) -> bool:
    """Whether the lane ``lane_index`` beside the ego has room for it now: no car alongside, none ahead within
    ``MERGE_GAP_M``, none behind within that plus ``MERGE_TIME_GAP_S`` of its speed plus its braking distance down
    to the ego's speed. J1 on a lane beside with a car alongside in it pulled the ego to the lane line, where it drove
    0.2-0.5 m from the car for 4 s and touched it when both braked for the queue (4459); another merged 2 m ahead of
    a car at its speed and was struck (4454; docs/traffic.md)."""
    ego_speed_mps = observation.ego.speed_mps
    for vehicle in observation.traffic:
        if vehicle.lane_index != lane_index or vehicle.lane_s_m is None:
            continue
        if vehicle.relation == "alongside" or vehicle.relation == "ahead" and vehicle.gap_m < MERGE_GAP_M:
            return False
        if vehicle.relation == "behind":
            closing_mps = max(0.0, vehicle.speed_mps - ego_speed_mps)
            room_m = (MERGE_GAP_M + MERGE_TIME_GAP_S * vehicle.speed_mps
                      + closing_mps**2 / (2.0 * MERGE_FOLLOWER_DECEL_MPS2))
            if vehicle.gap_m < room_m:
                return False
    return True


@dataclass(frozen=True, slots=True)
class _Passing:
    obstacle_id: str
    followed_lane: int
    tracked_lane: int
    started_in_line: bool
    """Started in the tracked lane, standing behind the obstacle or driving towards its queue: it lasts there too."""
    waits_for_room: bool = False
    """Started driving towards the queue: with ``Detour.merge_waits_from_mps``, while the ego's centre is in the
    tracked lane, J1 follows the lane beside only when it has room (:func:`room_to_merge`), else the tracked lane."""


class Detour:
    """The lane J1 follows while the ego passes a blockage of the lane J1 tracks.

    It starts in three ways, and lasts, for that blockage's obstacle, until the obstacle is behind the ego or the
    ego leaves the lanes it started in:
    - the ego's centre is in a lane beside the tracked one and a queue with cars in it stands ahead in the
      tracked lane within ``within_m``, or a lone stopped car at least ``BESIDE_LONE_OBSTACLE_FROM_M`` ahead
      (nearer, J2 takes the ego round it, as in the paper, unless the ego stands there, ``BESIDE_STANDING_MPS``;
      further back, pulled into line behind it the ego would only have to pull out again, as after a yield to the
      edge lane). Pulled back towards a queue instead, the
      ego stood wedged beside a car of it that stood to its side for 125 s (docs/traffic.md);
    - the ego stands in the tracked lane behind a lone stopped obstacle, as a queued car would (its front
      within ``QUEUE_LINK_M`` of the obstacle's rear, slower than ``QUEUE_STANDING_MPS``), already partly aside:
      J1 follows the lane on that side. In line, J0's queue room charges every plan that ends closer, and J1 on
      the blocked lane pulls back in line: a pull-out there is a narrow valley of the cost that 256 samples
      missed, and the ego stood 8 m behind a lone stopped car with the lane beside it free for 23 s to the end,
      the cars behind in every lane waiting for it (docs/traffic.md). Behind a queue's cars, pulling out is the
      zipper's merge, which J0's gap acceptance decides (started there too, the ego cut into the next lane's
      traffic at 2 m/s);
    - with ``ahead_m``, the ego drives in the tracked lane towards a queue with cars in it (:meth:`_ahead`): it
      merges while it moves. Seeing the queue only within its 2 s horizon, it braked from 15 m/s too late and
      swerved into a car beside, or stood nose to tail with the queue's last car (docs/traffic.md). With
      ``merge_waits_from_mps``, until its centre is in the lane beside, J1 follows it only while it has room
      (:func:`room_to_merge`)."""

    def __init__(self, ahead_m: float | None = None, merge_waits_from_mps: float | None = None) -> None:
        self._passing: _Passing | None = None
        self.ahead_m = ahead_m
        """With a value, a third start: :meth:`_ahead`."""
        self.merge_waits_from_mps = merge_waits_from_mps
        """With a value, the third start's merge waits for room while the ego is this fast (``SurroundingsConfig``):
        at speed a car alongside at the ego's speed stays there, and J1 held the ego pressed to the line beside it
        (4459); slower, cars pass by and J0's gap acceptance decides the zipper (waiting at a crawl too, the ego stood
        nose to tail in the queue with the lane beside crawling past it, 4639)."""
        self.waiting_decel_mps2: float | None = None
        """``MERGE_WAIT_DECEL_MPS2`` while the last :meth:`lane` kept J1 on the tracked lane for want of room."""

    def lane(self, observation: Observation, queues: tuple[Queue, ...], tracked_lane: int | None,
             within_m: float, lane_centres_m: tuple[float, ...], passing_side: str | None = None) -> int | None:
        """The lane to follow instead of ``tracked_lane``, or None to follow it. ``lane_centres_m``: each lane's
        centre line, from the road's, positive to the left; ``passing_side``: J3's preferred side, if any."""
        ego = observation.ego
        self.waiting_decel_mps2 = None
        if tracked_lane is None or not ego.lane_role:
            self._passing = None
            return None
        passing = self._passing
        if passing is not None and passing.tracked_lane == tracked_lane and (
                ego.lane_index == passing.followed_lane or passing.started_in_line and ego.lane_index == tracked_lane):
            obstacle = next((o for o in observation.obstacles if o.id == passing.obstacle_id), None)
            if obstacle is not None and obstacle.relation != "behind":
                return self._followed(observation, passing)
        self._passing = (self._beside(observation, queues, tracked_lane, within_m)
                         or self._in_queue(observation, queues, tracked_lane, lane_centres_m)
                         or self._ahead(observation, queues, tracked_lane, lane_centres_m, passing_side))
        return self._followed(observation, self._passing) if self._passing is not None else None

    def _followed(self, observation: Observation, passing: _Passing) -> int | None:
        """The lane J1 follows now while ``passing``: the tracked lane (None) while a merge waits for room."""
        ego = observation.ego
        waits_from = self.merge_waits_from_mps
        if (passing.waits_for_room and waits_from is not None and ego.lane_index == passing.tracked_lane
                and ego.speed_mps >= waits_from and not room_to_merge(observation, passing.followed_lane)):
            self.waiting_decel_mps2 = MERGE_WAIT_DECEL_MPS2
            return None
        return passing.followed_lane

    def _ahead(self, observation: Observation, queues: tuple[Queue, ...], tracked_lane: int,
               lane_centres_m: tuple[float, ...], passing_side: str | None) -> _Passing | None:
        """Driving in the tracked lane towards a queue with cars in it within ``ahead_m``: the lane beside on
        ``passing_side`` (or the other side where the road has no lane there), before the ego has to stop."""
        ego = observation.ego
        if self.ahead_m is None or ego.lane_index != tracked_lane or ego.speed_mps < QUEUE_STANDING_MPS:
            return None
        if any(e.distance_m <= self.ahead_m for e in observation.emergency_vehicles):
            return None  # its rescue corridor passes the queue: beside it, the ego stood in its way (docs/traffic.md)
        ahead = [q for q in queues
                 if q.lane_index == tracked_lane and q.members and 0.0 <= q.tail_gap_m <= self.ahead_m]
        if not ahead:
            return None
        queue = min(ahead, key=lambda q: q.tail_gap_m)
        here = lane_centres_m[tracked_lane]
        sides = (1.0, -1.0) if passing_side == "left" else (-1.0, 1.0)  # + is left; right first without a preference
        for side in sides:
            for lane in (tracked_lane - 1, tracked_lane + 1):
                if 0 <= lane < len(lane_centres_m) and (lane_centres_m[lane] - here) * side > 0.0:
                    return _Passing(queue.obstacle_id, lane, tracked_lane, True, waits_for_room=True)
        return None

    @staticmethod
    def _beside(observation: Observation, queues: tuple[Queue, ...], tracked_lane: int,
                within_m: float) -> _Passing | None:
        ego = observation.ego
        if abs(ego.lane_index - tracked_lane) != 1:
            return None
        standing = ego.speed_mps < BESIDE_STANDING_MPS
        return next((_Passing(q.obstacle_id, ego.lane_index, tracked_lane, False) for q in queues
                     if q.lane_index == tracked_lane and q.tail_gap_m <= within_m
                     and (q.members or standing or q.tail_gap_m >= BESIDE_LONE_OBSTACLE_FROM_M)), None)

    @staticmethod
    def _in_queue(observation: Observation, queues: tuple[Queue, ...], tracked_lane: int,
                  lane_centres_m: tuple[float, ...]) -> _Passing | None:
        ego = observation.ego
        if ego.lane_index != tracked_lane or ego.speed_mps >= QUEUE_STANDING_MPS:
            return None
        for queue in queues:
            if queue.lane_index != tracked_lane or queue.members or queue.tail_gap_m > QUEUE_LINK_M:
                continue  # behind a queue's cars it is the zipper's merge: J0's gap acceptance, from the lane beside
            aside = ego.lateral_offset_m - queue.tail.lateral_offset_m  # from the car itself, as J0's room
            if abs(aside) < PULL_OUT_ASIDE_M:
                continue
            here = lane_centres_m[tracked_lane]
            for lane in (tracked_lane - 1, tracked_lane + 1):  # the one on that side, if the road has it
                if 0 <= lane < len(lane_centres_m) and (lane_centres_m[lane] - here) * aside > 0.0:
                    return _Passing(queue.obstacle_id, lane, tracked_lane, True)
        return None
