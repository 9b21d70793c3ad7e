"""The numbers a run is judged by (the columns of ``summary.csv``, written by the recorder; meanings in the README).

:class:`MetricsRecorder` sees every observation while the run goes (gaps, time to collision, emergency
vehicles, obstacle clearance, collision episodes); :func:`summarise` turns that and the trajectory into one
row, :func:`obstacle_rows` into one row per obstacle (``obstacle_passes.csv``, columns
:data:`~agentic_mpc.run.files.OBSTACLE_PASS_COLUMNS`).

Collisions are contact EPISODES of the ego with another road user (SUMO's reports and our own box overlap;
one episode per vehicle until they have been apart for half a second), each with a cause and whether the ego
was at fault (:mod:`agentic_mpc.world.collisions`: it struck the one ahead, its own lateral motion / lane
change brought them together, or it drove into a stopped car or obstacle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from agentic_mpc.primitives import Circle
from agentic_mpc.run.junction_log import JunctionLog
from agentic_mpc.run.stuck import StuckTracker, resume_to_v_ref_s
from agentic_mpc.world.collisions import CollisionTracker
from agentic_mpc.world.observation import Observation

if TYPE_CHECKING:
    import pandas as pd

@dataclass
class ObstacleTrack:
    """One static obstacle: its discs, where it is along the road, and how close the ego came."""

    id: str
    circles: tuple[Circle, ...]
    road_s_m: float
    lane_index: int
    min_clearance_m: float = math.inf
    side: str = "none"
    """The ego's side of the obstacle's lane as it passed it ("left"/"right"), "none" until then, "behind at
    start" when the ego entered the road past it (SUMO inserts the ego in the nearest free gap)."""
    passed_at_s: float = math.nan
    """Simulation time at which the ego's centre passed the obstacle's along the road."""


@dataclass
class MetricsRecorder:
    """Running extrema over the observations of one run."""

    obstacles: list[ObstacleTrack] = field(default_factory=list)
    min_gap_m: float = math.inf
    min_ttc_s: float = math.inf
    emergency_time_loss_s: dict[str, float] = field(default_factory=dict)
    ego_collision_pairs: set[tuple[str, str]] = field(default_factory=set)
    """Every (sorted) pair of ids that touched, the ego one of them, over the run."""
    collisions: CollisionTracker = field(default_factory=CollisionTracker)
    """The contact episodes with their causes."""
    stuck: StuckTracker = field(default_factory=StuckTracker)
    """When the ego stood still although asked to move (:mod:`agentic_mpc.run.stuck`)."""
    junctions: JunctionLog = field(default_factory=JunctionLog)
    """How it went through the junctions of its route (:mod:`agentic_mpc.run.junction_log`)."""
    _previous_road_s_m: float | None = None
    last_time_s: float = math.nan

    def observe(self, observation: Observation, lateral_of_lane: Any, v_ref_mps: float = math.nan) -> None:
        """``lateral_of_lane(index, x, y)``: the ego's signed offset from a road lane (+ left); ``v_ref_mps``:
        the speed the specification asks for."""
        ego = observation.ego
        self.stuck.update(observation, v_ref_mps)
        if observation.junctions_ahead or self.junctions.junction_ids_ahead:
            self.junctions.observe(observation)
        for vehicle in observation.traffic:
            if vehicle.relative_lane != 0:
                continue
            self.min_gap_m = min(self.min_gap_m, vehicle.gap_m)
            if vehicle.relation == "ahead":
                closing = ego.speed_mps - vehicle.speed_mps
            elif vehicle.relation == "behind":
                closing = vehicle.speed_mps - ego.speed_mps
            else:
                continue
            if closing > 1e-6:
                self.min_ttc_s = min(self.min_ttc_s, max(vehicle.gap_m, 0.0) / closing)
        for collision in observation.collisions:
            if collision.ego_contact:
                self.ego_collision_pairs.add(tuple(sorted((collision.collider, collision.victim))))
        self.collisions.update(observation)
        for track in self.obstacles:
            for circle in track.circles:
                clearance = math.hypot(ego.x_m - circle.x_m, ego.y_m - circle.y_m) - circle.radius_m
                track.min_clearance_m = min(track.min_clearance_m, clearance)
            passing = self._previous_road_s_m is not None and self._previous_road_s_m < track.road_s_m <= ego.road_s_m
            if passing and track.side == "none":
                track.side = "left" if lateral_of_lane(track.lane_index, ego.x_m, ego.y_m) > 0 else "right"
                track.passed_at_s = observation.time_s
        self._previous_road_s_m = ego.road_s_m
        self.last_time_s = observation.time_s

    def record_time_loss(self, vehicle_id: str, time_loss_s: float) -> None:
        self.emergency_time_loss_s[vehicle_id] = time_loss_s


def summarise(
    trajectory: pd.DataFrame,
    recorder: MetricsRecorder,
    *,
    goal_s_m: float,
    agent_tool_calls: int,
) -> dict[str, Any]:
    """One row of ``summary.csv`` (without the identifying columns)."""
    import pandas as pd

    def finite_or_nan(value: float) -> float:
        return round(value, 4) if math.isfinite(value) else float("nan")

    obstacle_side = ""
    min_clearance = float("nan")
    if recorder.obstacles:
        obstacle_side = obstacle_outcome(recorder.obstacles[0], recorder)  # the first one; all: obstacle_rows
        min_clearance = min(track.min_clearance_m for track in recorder.obstacles)
    reached = trajectory["road_s_m"] >= goal_s_m if len(trajectory) else pd.Series(dtype=bool)
    # the trajectory's rows are the states the controller acted on: the step that reached the goal ended the run
    reached_at_end = not reached.any() and (recorder._previous_road_s_m or -math.inf) >= goal_s_m
    solve_ms = trajectory["solve_ms"] if len(trajectory) else pd.Series(dtype=float)
    return {
        "steps": len(trajectory),
        "sim_time_s": round(float(trajectory["time_s"].iloc[-1]) if len(trajectory) else 0.0, 3),
        "collisions": len(recorder.collisions.episodes),
        "collisions_ego_at_fault": recorder.collisions.at_fault,
        "sumo_reports_without_contact": len(recorder.collisions.reports_without_contact),
        "reached_goal": bool(reached.any()) or reached_at_end,
        **recorder.junctions.summary(route_completed=bool(reached.any()) or reached_at_end),
        "obstacle_side": obstacle_side,
        "min_obstacle_clearance_m": finite_or_nan(min_clearance),
        "blockages_passed": sum(1 for track in recorder.obstacles if math.isfinite(track.passed_at_s)),
        "blockages_ahead_at_start": sum(1 for track in recorder.obstacles if track.side != "behind at start"),
        "stuck_s": round(recorder.stuck.longest_s, 3),
        "stuck_reason": recorder.stuck.longest_reason,
        "resume_to_v_ref_s": resume_to_v_ref_s(trajectory["time_s"], trajectory["v_mps"], trajectory["v_ref_mps"])
        if len(trajectory) and "v_ref_mps" in trajectory else float("nan"),
        "min_gap_m": finite_or_nan(recorder.min_gap_m),
        "min_ttc_s": finite_or_nan(recorder.min_ttc_s),
        "lane_rms_error_m": finite_or_nan(float(np.sqrt(np.mean(trajectory["tracked_lane_offset_m"] ** 2))))
        if len(trajectory)
        else float("nan"),
        "mean_speed_mps": finite_or_nan(float(trajectory["v_mps"].mean())) if len(trajectory) else float("nan"),
        "time_to_goal_s": round(float(trajectory["time_s"][reached].iloc[0]), 3) if reached.any()
        else round(recorder.last_time_s, 3) if reached_at_end else float("nan"),
        "ambulance_delay_s": finite_or_nan(max(recorder.emergency_time_loss_s.values()))
        if recorder.emergency_time_loss_s
        else float("nan"),
        "agent_tool_calls": agent_tool_calls,
        "controller_ms_median": finite_or_nan(float(solve_ms.median())) if len(solve_ms) else float("nan"),
        "controller_ms_p99": finite_or_nan(float(solve_ms.quantile(0.99))) if len(solve_ms) else float("nan"),
    }


def obstacle_outcome(track: ObstacleTrack, recorder: MetricsRecorder) -> str:
    """"hit" (the ego entered its discs or touched it), else the side it passed on, "none" if it did not."""
    hit = track.min_clearance_m < 0 or any(track.id in pair for pair in recorder.ego_collision_pairs)
    return "hit" if hit else track.side


def obstacle_rows(recorder: MetricsRecorder) -> list[dict[str, Any]]:
    """One row per static obstacle (``obstacle_passes.csv``): how the ego went past EACH of them. ``side`` as
    the summary's ``obstacle_side`` (which is this for the first obstacle); ``min_clearance_m`` from its own
    discs (the ego's centre to their boundary, negative inside); ``passed_at_s`` NaN if never passed."""

    def number(value: float) -> float:
        return round(value, 4) if math.isfinite(value) else float("nan")

    return [
        {"id": track.id, "lane_index": track.lane_index, "road_s_m": number(track.road_s_m),
         "side": obstacle_outcome(track, recorder), "min_clearance_m": number(track.min_clearance_m),
         "passed_at_s": number(track.passed_at_s)}
        for track in recorder.obstacles
    ]
