"""The numbers a run is judged by (the columns of ``summary.csv``; meanings in the README).

:class:`MetricsRecorder` sees every observation while the run goes (gaps, time to collision, emergency
vehicles, obstacle clearance); :func:`summarise` turns that and the trajectory into one row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from agentic_mpc.primitives import Circle
from agentic_mpc.world.observation import Observation

if TYPE_CHECKING:
    import pandas as pd

TIMING_COLUMNS = ("solve_ms", "step_ms", "controller_ms_median", "controller_ms_p99", "wall_s")
"""Wall-clock columns: the only ones a seed cannot fix (every other column is reproducible)."""


@dataclass
class ObstacleTrack:
    """One static obstacle: its discs, where it is along the road, and how close the ego came."""

    id: str
    circles: tuple[Circle, ...]
    road_s_m: float
    lane_index: int
    min_clearance_m: float = math.inf
    side: str = "none"


@dataclass
class MetricsRecorder:
    """Running extrema over the observations of one run."""

    obstacles: list[ObstacleTrack] = field(default_factory=list)
    min_gap_m: float = math.inf
    min_ttc_s: float = math.inf
    emergency_time_loss_s: dict[str, float] = field(default_factory=dict)
    ego_collision_pairs: set[tuple[str, str]] = field(default_factory=set)
    _previous_road_s_m: float | None = None

    def observe(self, observation: Observation, lateral_of_lane: Any) -> None:
        """``lateral_of_lane(index, x, y)``: the ego's signed offset from a road lane (+ left)."""
        ego = observation.ego
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
            if collision.involves_ego:
                self.ego_collision_pairs.add(tuple(sorted((collision.collider, collision.victim))))
        for track in self.obstacles:
            for circle in track.circles:
                clearance = math.hypot(ego.x_m - circle.x_m, ego.y_m - circle.y_m) - circle.radius_m
                track.min_clearance_m = min(track.min_clearance_m, clearance)
            passing = self._previous_road_s_m is not None and self._previous_road_s_m < track.road_s_m <= ego.road_s_m
            if passing and track.side == "none":
                track.side = "left" if lateral_of_lane(track.lane_index, ego.x_m, ego.y_m) > 0 else "right"
        self._previous_road_s_m = ego.road_s_m

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
        first = recorder.obstacles[0]
        hit = first.min_clearance_m < 0 or any(first.id in pair for pair in recorder.ego_collision_pairs)
        obstacle_side = "hit" if hit else first.side
        min_clearance = min(track.min_clearance_m for track in recorder.obstacles)
    reached = trajectory["road_s_m"] >= goal_s_m if len(trajectory) else pd.Series(dtype=bool)
    solve_ms = trajectory["solve_ms"] if len(trajectory) else pd.Series(dtype=float)
    return {
        "steps": len(trajectory),
        "sim_time_s": round(float(trajectory["time_s"].iloc[-1]) if len(trajectory) else 0.0, 3),
        "collisions": len(recorder.ego_collision_pairs),
        "reached_goal": bool(reached.any()),
        "obstacle_side": obstacle_side,
        "min_obstacle_clearance_m": finite_or_nan(min_clearance),
        "min_gap_m": finite_or_nan(recorder.min_gap_m),
        "min_ttc_s": finite_or_nan(recorder.min_ttc_s),
        "lane_rms_error_m": finite_or_nan(float(np.sqrt(np.mean(trajectory["tracked_lane_offset_m"] ** 2))))
        if len(trajectory)
        else float("nan"),
        "mean_speed_mps": finite_or_nan(float(trajectory["v_mps"].mean())) if len(trajectory) else float("nan"),
        "time_to_goal_s": round(float(trajectory["time_s"][reached].iloc[0]), 3) if reached.any() else float("nan"),
        "ambulance_delay_s": finite_or_nan(max(recorder.emergency_time_loss_s.values()))
        if recorder.emergency_time_loss_s
        else float("nan"),
        "agent_tool_calls": agent_tool_calls,
        "controller_ms_median": finite_or_nan(float(solve_ms.median())) if len(solve_ms) else float("nan"),
        "controller_ms_p99": finite_or_nan(float(solve_ms.quantile(0.99))) if len(solve_ms) else float("nan"),
    }
