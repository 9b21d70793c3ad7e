"""LaMPilot-Bench's success criteria and driving score, judged step by step on what the world observes.

As the README beside LaMPilot's data states them (``eval.type``), with the evaluator's 60 s limit from the
command; any case also fails on a collision (our footprint check) or on leaving the road:

- ``ACCEvalbySpeed``: the speed within 1 m/s of the target (``speed``, or the speed at the command +
  ``rel_speed``), or, with a slower leader within 100 m, within 1 m/s of its speed, held for 5 s;
- ``ACCEvalbyDistance``: the gap to the leader within +-30 % of the target (``distance``, or the gap at the
  command + ``rel_distance``), held for 5 s; a leader must be within 100 m at the command;
- ``LaneChangeEval``: in the adjacent lane on that side of the start lane, heading within 5 degrees of the lane's;
- ``OvertakeEval``: in the adjacent lane on that side and more than two car lengths ahead of the leader it had
  at the command;
- ``PullOverEval``: in the emergency (right-most) lane below 0.5 m/s;
- ``IntersectionEval`` (``direction`` = [lane start, exit, index]): on the named exit (``o1`` left, ``o2``
  straight, ``o3`` right of the crossroad, :data:`EXITS`) with the heading within 5 degrees of its lane's (LaMPilot's
  0.1 degree is an artefact of highway-env's cars, which snap to their lanes; a car that steers needs the lane
  change criterion's tolerance).

Driving score of a success: 0.5 TTC score + 0.3 speed-variance score + 0.2 time-efficiency score (each
0-100; a failure scores 0).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

TIME_LIMIT_S = 60.0
HOLD_S = 5.0
SPEED_TOLERANCE_MPS = 1.0
GAP_TOLERANCE = 0.3
LEADER_RANGE_M = 100.0
HEADING_TOLERANCE_DEG = 5.0
CAR_LENGTH_M = 5.0
"""highway-env's vehicle length: an overtake is done two of these (centre to centre) past the car."""
STOPPED_MPS = 0.5
EXITS = {"o1": "west_out", "o2": "north_out", "o3": "east_out"}
"""LaMPilot's exits of the crossroad from the ego's south approach, as the edges of ``lampilot_crossroad``."""


@dataclass(frozen=True)
class StepView:
    """What a criterion reads at one step (times from the command)."""

    time_s: float
    speed_mps: float
    lane: int | None
    """Position from the left (highway-env's lane index: 0 is the left-most); None off the road."""
    shoulder: int | None
    """The emergency lane's position from the left, if the road has one."""
    heading_error_deg: float
    off_road: bool
    collided: bool
    road_s_m: float
    leader_id: str | None = None
    leader_gap_m: float | None = None
    leader_speed_mps: float | None = None
    positions: Mapping[str, float] = field(default_factory=dict)
    """Along-road centre positions of the vehicles in view."""
    edge_id: str = ""
    """The network edge the ego is on ('' inside a junction or off the road)."""

    @property
    def time_to_collision_s(self) -> float:
        if self.leader_gap_m is None or self.leader_speed_mps is None:
            return math.inf
        closing = self.speed_mps - self.leader_speed_mps
        return max(self.leader_gap_m, 0.0) / closing if closing > 1e-6 else math.inf


@dataclass
class Verdict:
    success: bool
    reason: str
    time_s: float


class Judge:
    """Feed it every step's :class:`StepView` (:meth:`update`); it returns a :class:`Verdict` once decided."""

    def __init__(self, evaluation: Mapping[str, Any], first: StepView) -> None:
        self.kind = str(evaluation["type"])
        self.evaluation = dict(evaluation)
        self.start = first
        self.held_since_s: float | None = None
        self.speeds: list[float] = []
        self.min_ttc_s = math.inf
        self.verdict: Verdict | None = None
        self.target: float | None = None
        if self.kind == "ACCEvalbySpeed":
            self.target = (float(evaluation["speed"]) if "speed" in evaluation
                           else first.speed_mps + float(evaluation["rel_speed"]))
        elif self.kind == "ACCEvalbyDistance":
            if first.leader_gap_m is not None:
                self.target = (float(evaluation["distance"]) if "distance" in evaluation
                               else first.leader_gap_m + float(evaluation["rel_distance"]))
        self.start_leader = first.leader_id

    def update(self, view: StepView) -> Verdict | None:
        if self.verdict is not None:
            return self.verdict
        self.speeds.append(view.speed_mps)
        self.min_ttc_s = min(self.min_ttc_s, view.time_to_collision_s)
        if view.collided:
            return self._decide(False, "collision", view)
        if view.off_road:
            return self._decide(False, "left the road", view)
        if self.kind == "ACCEvalbyDistance" and self.target is None:
            return self._decide(False, "no leader within 100 m at the command", view)
        if self.kind == "OvertakeEval" and self.start_leader is None:
            return self._decide(False, "no leader to overtake at the command", view)
        met = self._met(view)
        if met and self.kind in ("ACCEvalbySpeed", "ACCEvalbyDistance"):
            if self.held_since_s is None:
                self.held_since_s = view.time_s
            if view.time_s - self.held_since_s >= HOLD_S - 1e-9:
                return self._decide(True, f"held for {HOLD_S:g} s", view)
        elif met:
            return self._decide(True, "reached", view)
        else:
            self.held_since_s = None
        if view.time_s >= TIME_LIMIT_S - 1e-9:
            return self._decide(False, f"not met within {TIME_LIMIT_S:g} s", view)
        return None

    def _met(self, view: StepView) -> bool:
        if self.kind == "ACCEvalbySpeed":
            target = self.target
            slower_leader = (view.leader_speed_mps is not None and view.leader_gap_m is not None
                             and view.leader_gap_m <= LEADER_RANGE_M and view.leader_speed_mps < target)
            if slower_leader:
                target = view.leader_speed_mps
            return abs(view.speed_mps - target) <= SPEED_TOLERANCE_MPS
        if self.kind == "ACCEvalbyDistance":
            return view.leader_gap_m is not None and abs(view.leader_gap_m - self.target) <= GAP_TOLERANCE * self.target
        if self.kind in ("LaneChangeEval", "OvertakeEval"):
            if self.start.lane is None or view.lane is None:
                return False
            step = -1 if self.evaluation["direction"] == "left" else 1
            in_lane = view.lane == self.start.lane + step and view.lane != view.shoulder
            if self.kind == "LaneChangeEval":
                return in_lane and abs(view.heading_error_deg) <= HEADING_TOLERANCE_DEG
            passed = view.positions.get(self.start_leader)
            return in_lane and passed is not None and view.road_s_m - passed > 2.0 * CAR_LENGTH_M
        if self.kind == "IntersectionEval":
            exit_edge = EXITS.get(str(self.evaluation["direction"][1]))
            return view.edge_id == exit_edge and abs(view.heading_error_deg) <= HEADING_TOLERANCE_DEG
        if self.kind == "PullOverEval":
            return view.shoulder is not None and view.lane == view.shoulder and view.speed_mps < STOPPED_MPS
        return False

    def _decide(self, success: bool, reason: str, view: StepView) -> Verdict:
        self.verdict = Verdict(success, reason, view.time_s)
        return self.verdict

    def time_out(self, view: StepView) -> Verdict:
        """The run ended before the criterion was decided (the world's end, a failure of the run)."""
        return self.verdict or self._decide(False, f"the run ended at {view.time_s:.1f} s undecided", view)

    @staticmethod
    def failed_scores() -> dict[str, float]:
        return {"score": 0.0, "ttc_score": 0.0, "speed_variance_score": 0.0, "time_efficiency_score": 0.0}

    def scores(self) -> dict[str, float]:
        """LaMPilot's driving score and its parts (0 for a failure)."""
        if self.verdict is None or not self.verdict.success:
            return self.failed_scores()
        ttc = 100.0 if self.min_ttc_s > 2.0 else 100.0 - 1.0 / max(self.min_ttc_s, 1e-3)
        variance = 100.0 * (1.0 - float(np.std(self.speeds)) / 10.0)
        efficiency = 100.0 * (1.0 - self.verdict.time_s / TIME_LIMIT_S)
        ttc, variance, efficiency = (min(100.0, max(0.0, x)) for x in (ttc, variance, efficiency))
        return {"score": round(0.5 * ttc + 0.3 * variance + 0.2 * efficiency, 3), "ttc_score": round(ttc, 3),
                "speed_variance_score": round(variance, 3), "time_efficiency_score": round(efficiency, 3)}
