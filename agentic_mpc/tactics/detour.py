"""The lane J1 follows while the ego passes a blockage of the lane J1 tracks: three rules that can start a detour,
and :class:`Detour`, which keeps it until the blockage's obstacle is behind the ego.

Each start is one rule (:mod:`agentic_mpc.tactics.config` has its parameters):
- ``pass_beside_queue``: the ego's centre is in a lane beside the tracked one and a queue with cars in it stands
  ahead in the tracked lane, or a lone stopped car far enough ahead (nearer, J2 takes the ego round it, as in the
  paper, unless the ego stands there). Pulled back towards a queue instead, the ego stood wedged beside a car of it
  for 125 s;
- ``pull_out_past_stopped_car``: the ego stands in the tracked lane behind a lone stopped car, as a queued car
  would, already partly aside: J1 follows the lane on that side. In line, J0's queue room charges every plan that
  ends closer and J1 on the blocked lane pulls back in line, a narrow valley of the cost that 256 samples missed:
  the ego stood 8 m behind a lone stopped car with the lane beside free for 23 s. Behind a queue's cars, pulling
  out is the zipper's merge, which J0's gap acceptance decides;
- ``merge_ahead_of_queue``: the ego drives in the tracked lane towards a queue with cars in it: J1 follows the lane
  beside on J3's preferred side (the other where the road has none), so that it merges while it moves. Seeing the
  queue only within its 2 s horizon, it braked from 15 m/s too late and swerved into a car beside, or stood nose to
  tail with the queue's last car. Not while an emergency vehicle is that close: its rescue corridor passes the
  queue, and beside it the ego stood in its way.
"""

from __future__ import annotations

from dataclasses import dataclass

from agentic_mpc.tactics.config import TacticsConfig
from agentic_mpc.tactics.queues import QUEUE_LINK_M, QUEUE_STANDING_MPS, Queue
from agentic_mpc.world.observation import Observation


@dataclass(frozen=True, slots=True)
class Passing:
    """A detour under way: which rule started it, past which obstacle, the lane followed instead of the tracked."""

    rule: str
    obstacle_id: str
    followed_lane: int
    tracked_lane: int
    started_in_line: bool
    """Started in the tracked lane (standing behind the obstacle, or driving towards its queue): it lasts there too."""


def pass_beside_queue(observation: Observation, queues: tuple[Queue, ...], tracked_lane: int,
                      config: TacticsConfig) -> Passing | None:
    ego = observation.ego
    if abs(ego.lane_index - tracked_lane) != 1:
        return None
    rule = config.pass_beside_queue
    standing = ego.speed_mps < rule.standing_mps
    return next((Passing("pass_beside_queue", q.obstacle_id, ego.lane_index, tracked_lane, False) for q in queues
                 if q.lane_index == tracked_lane and q.tail_gap_m <= rule.within_m
                 and (q.members or standing or q.tail_gap_m >= rule.lone_obstacle_from_m)), None)


def pull_out_past_stopped_car(observation: Observation, queues: tuple[Queue, ...], tracked_lane: int,
                              lane_centres_m: tuple[float, ...], config: TacticsConfig) -> Passing | None:
    ego = observation.ego
    if ego.lane_index != tracked_lane or ego.speed_mps >= QUEUE_STANDING_MPS:
        return None
    for queue in queues:
        if queue.lane_index != tracked_lane or queue.members or queue.tail_gap_m > QUEUE_LINK_M:
            continue  # behind a queue's cars it is the zipper's merge: J0's gap acceptance, from the lane beside
        aside = ego.lateral_offset_m - queue.tail.lateral_offset_m  # from the car itself, as J0's room
        if abs(aside) < config.pull_out_past_stopped_car.aside_m:
            continue
        lane = _beside(tracked_lane, lane_centres_m, 1.0 if aside > 0.0 else -1.0)
        if lane is not None:
            return Passing("pull_out_past_stopped_car", queue.obstacle_id, lane, tracked_lane, True)
    return None


def merge_ahead_of_queue(observation: Observation, queues: tuple[Queue, ...], tracked_lane: int,
                         lane_centres_m: tuple[float, ...], passing_side: str | None,
                         config: TacticsConfig) -> Passing | None:
    ego = observation.ego
    within_m = config.merge_ahead_of_queue.within_m
    if ego.lane_index != tracked_lane or ego.speed_mps < QUEUE_STANDING_MPS:
        return None
    if any(e.distance_m <= within_m for e in observation.emergency_vehicles):
        return None
    ahead = [q for q in queues if q.lane_index == tracked_lane and q.members and 0.0 <= q.tail_gap_m <= within_m]
    if not ahead:
        return None
    queue = min(ahead, key=lambda q: q.tail_gap_m)
    for side in (1.0, -1.0) if passing_side == "left" else (-1.0, 1.0):  # + is left; right first without a preference
        lane = _beside(tracked_lane, lane_centres_m, side)
        if lane is not None:
            return Passing("merge_ahead_of_queue", queue.obstacle_id, lane, tracked_lane, True)
    return None


def _beside(lane: int, lane_centres_m: tuple[float, ...], side: float) -> int | None:
    """The lane next to ``lane`` on ``side`` (+1 left, -1 right), if the road has one."""
    here = lane_centres_m[lane]
    return next((other for other in (lane - 1, lane + 1)
                 if 0 <= other < len(lane_centres_m) and (lane_centres_m[other] - here) * side > 0.0), None)


class Detour:
    """Which lane J1 follows: a detour, once started by a rule in force, lasts for its obstacle until the obstacle
    is behind the ego or the ego leaves the lanes it started in."""

    def __init__(self, config: TacticsConfig) -> None:
        self.config = config
        self.passing: Passing | None = None

    def lane(self, observation: Observation, queues: tuple[Queue, ...], tracked_lane: int | None,
             lane_centres_m: tuple[float, ...], passing_side: str | None = None) -> int | None:
        """The lane to follow instead of ``tracked_lane``, or None to follow it. ``lane_centres_m``: each lane's
        centre line, from the road's, positive to the left; ``passing_side``: J3's preferred side, if any."""
        ego = observation.ego
        if tracked_lane is None or not ego.lane_role:
            self.passing = None
            return None
        passing = self.passing
        if passing is not None and passing.tracked_lane == tracked_lane and (
                ego.lane_index == passing.followed_lane or passing.started_in_line and ego.lane_index == tracked_lane):
            obstacle = next((o for o in observation.obstacles if o.id == passing.obstacle_id), None)
            if obstacle is not None and obstacle.relation != "behind":
                return passing.followed_lane
        uses, config = self.config.uses, self.config
        self.passing = (
            uses("pass_beside_queue") and pass_beside_queue(observation, queues, tracked_lane, config)
            or uses("pull_out_past_stopped_car")
            and pull_out_past_stopped_car(observation, queues, tracked_lane, lane_centres_m, config)
            or uses("merge_ahead_of_queue")
            and merge_ahead_of_queue(observation, queues, tracked_lane, lane_centres_m, passing_side, config)
            or None)
        return self.passing.followed_lane if self.passing is not None else None
