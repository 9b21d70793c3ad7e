"""What the ego is about to do, told to SUMO's drivers: the lane its plan enters and who should let it in.

The ego is driven by ``moveToXY``, so SUMO's lane-change model never runs for it: its drivers neither see a
blinker they react to nor get the cooperation requests they send each other, and the part of the ego that
sticks into their lane is invisible to them until its centre crosses the line (``../shared/notes/sumo.md``).
The controller's gap acceptance predicts that a follower in a lane the ego enters beside a blockage brakes
at up to the tactics' ``gap_acceptance.follower_yield_mps2`` to let it in; this makes that true in SUMO. From the
controller's plan the world finds the lane the ego's body is about to enter and asks the followers in that
lane to open a gap behind the ego (``vehicle.openGap`` with the ego as the reference vehicle and that
deceleration as the most they brake for it). Its blinker would tell them nothing: SUMO's drivers do not read
each other's blinkers, and SUMO switches a TraCI-set blinker off after one step (measured, SUMO 1.28).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agentic_mpc.sumo.network import Road
from agentic_mpc.world.observation import Observation

MIN_LATERAL_MOVE_M = 0.3
"""How much further sideways than now the plan must take the ego for a lane change to be announced."""


@dataclass(frozen=True, slots=True)
class GapRequest:
    """Ask ``follower_id`` to keep a gap behind the ego for ``duration_s`` (renewed while the intention holds)."""

    follower_id: str
    time_headway_s: float
    space_headway_m: float
    duration_s: float
    max_decel_mps2: float


@dataclass(frozen=True, slots=True)
class Intention:
    """The lane the ego's plan enters (None: it stays in its lane), on which side, and the requests."""

    lane_index: int | None
    side: str | None  # "left" | "right"
    requests: tuple[GapRequest, ...] = ()


class IntentionReader:
    """Reads the ego's lane-change intention from the controller's plan (positions over the horizon)."""

    def __init__(
        self,
        road: Road,
        ego_width_m: float,
        *,
        follower_range_m: float = 50.0,
        max_decel_mps2: float = 2.0,
        time_headway_s: float = 1.0,
        space_headway_m: float = 2.5,
        renew_s: float = 1.0,
    ) -> None:
        self.road = road
        self.half_width_m = 0.5 * ego_width_m
        self.follower_range_m = follower_range_m
        self.max_decel_mps2 = max_decel_mps2
        self.time_headway_s = time_headway_s
        self.space_headway_m = space_headway_m
        self.renew_s = renew_s
        # Lanes run parallel to the road's centre line: each lane's (left, right) bound from it, by lane index.
        bounds, left = {}, 0.5 * road.width_m
        for index in road.left_to_right:
            bounds[index] = (left, left - road.lane_widths_m[index])
            left -= road.lane_widths_m[index]
        self._bounds = bounds

    def _lane_at(self, lateral_m: float) -> int | None:
        for index, (left, right) in self._bounds.items():
            if right <= lateral_m < left:
                return index
        return None

    def read(self, observation: Observation, planned_xy: np.ndarray) -> Intention:
        """``planned_xy``: (H, 2) centre positions of the plan. The lane entered is the one the body's edge
        reaches beyond the ego's lane on the side the plan moves to, if the plan moves it at least
        ``MIN_LATERAL_MOVE_M`` further that way: a standing ego that sticks out is announcing nothing (asked
        to wait behind it, followers stood there for good)."""
        ego = observation.ego
        lateral = self.road.lateral_from_reference(planned_xy[:, 0], planned_xy[:, 1])
        now = float(self.road.lateral_from_reference(ego.x_m, ego.y_m)[0])
        current = self._lane_at(now)
        if current is None:
            return Intention(None, None)
        left_bound, right_bound = self._bounds[current]
        # lateral is positive to the left: how much further each way than now the plan goes, and the body's
        # edge there.
        moved_left, moved_right = float(lateral.max()) - now, now - float(lateral.min())
        reach_left, reach_right = float(lateral.max()) + self.half_width_m, float(lateral.min()) - self.half_width_m
        if moved_left >= max(moved_right, MIN_LATERAL_MOVE_M) and reach_left > left_bound:
            side, lane = "left", self._lane_at(reach_left)
        elif moved_right >= max(moved_left, MIN_LATERAL_MOVE_M) and reach_right < right_bound:
            side, lane = "right", self._lane_at(reach_right)
        else:
            return Intention(None, None)
        if lane is None or lane == current:
            return Intention(None, None)
        requests = tuple(
            GapRequest(v.id, self.time_headway_s, self.space_headway_m, self.renew_s, self.max_decel_mps2)
            for v in observation.traffic
            if v.lane_index == lane and v.vclass != "emergency"
            and 0.0 < ego.road_s_m - v.road_s_m - 0.5 * (ego.length_m + v.length_m) <= self.follower_range_m
            and v.speed_mps > 0.5
        )
        return Intention(lane, side, requests)
