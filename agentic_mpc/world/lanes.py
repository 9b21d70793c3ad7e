"""The lanes of the ego's road, as every world gives them and the tools and the specification builder use them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

from agentic_mpc.geometry import LanePath


class RoadLanes(NamedTuple):
    """The ego road's lane centre lines by role ("center", "left", "right"; a road may have fewer), its speed
    limit, and which side traffic keeps to."""

    lanes: Mapping[str, LanePath]
    speed_limit_mps: float
    lefthand: bool = False
    by_index: tuple[LanePath, ...] = ()
    """Every lane's centre line by the world's lane index (SUMO's: 0 is the edge lane); empty if the world
    names only the roles."""
    left_to_right: tuple[int, ...] = ()
    """The lane indices from the road's left edge to its right."""
    shoulder_index: int | None = None
    """The emergency lane (a hard shoulder: for stopping, not driving), if the road has one."""

    def label(self, index: int) -> str:
        """The name of lane ``index``: its role ("left", "center", "right") where it has one, else ``lane<i>``."""
        path = self.by_index[index]
        return next((role for role, p in self.lanes.items() if p is path), f"lane{index}")

    def neighbour(self, index: int, side: str) -> int | None:
        """The lane to the ``side`` ("left"/"right") of lane ``index``, or None at the edge of the road."""
        position = self.left_to_right.index(index) + (-1 if side == "left" else 1)
        return self.left_to_right[position] if 0 <= position < len(self.left_to_right) else None

    def position_from_left(self, index: int) -> int:
        """0 for the leftmost lane, 1 for the next, ... (highway-env's and LaMPilot's numbering)."""
        return self.left_to_right.index(index)


LEADER_RANGE_M = 100.0
"""How far ahead a vehicle in the ego's lane counts as its leader for the tools (LaMPilot's evaluator: 100 m)."""


class Situation(NamedTuple):
    """What the tools read of the ego now: its lane, speed and the vehicle ahead of it in its lane."""

    time_s: float
    lane_index: int | None
    speed_mps: float
    road_s_m: float
    length_m: float
    leader_id: str | None = None
    leader_gap_m: float | None = None
    """Bumper to bumper, along the road."""
    leader_speed_mps: float | None = None
    positions: Mapping[str, tuple[float, int | None]] = {}
    """Every vehicle in view: (along-road position of its centre, its lane index or None off the road)."""


def situation_of(observation: Any, leader_range_m: float = LEADER_RANGE_M) -> Situation:
    """The :class:`Situation` of an :class:`~agentic_mpc.world.observation.Observation`."""
    ego = observation.ego
    ahead = [v for v in observation.traffic
             if v.relation == "ahead" and v.relative_lane == 0 and 0.0 <= v.gap_m <= leader_range_m]
    leader = min(ahead, key=lambda v: v.gap_m, default=None)
    positions = {v.id: (v.road_s_m, v.lane_index if v.relative_lane is not None else None) for v in observation.traffic}
    return Situation(
        observation.time_s, ego.lane_index, ego.speed_mps, ego.road_s_m, ego.length_m,
        leader.id if leader else None, leader.gap_m if leader else None, leader.speed_mps if leader else None,
        positions,
    )
