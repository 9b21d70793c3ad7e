"""Ride comfort and solver health: what a passenger feels and how well the MPPI average is doing.

Computed by the recorder from the run's trajectory as it writes ``trajectory.csv`` (the motion columns) and
``summary.csv`` (README, "Metrics"):

- acceleration and jerk are finite differences of the plant's speed (the ego is driven by the model, so
  this is what the passenger feels along the road); the steering rate is that of the normalised command;
- every number exists twice: over the whole run, and over its **steady cruise** (``cruise_*``), the steps
  where nothing asks the car to change what it does. A step is cruise when the specification has been the
  same for at least ``SETTLE_S`` and the car has since settled (speed within ``SPEED_BAND_MPS`` of v_ref and
  within ``LATERAL_BAND_M`` of its lane once), no static obstacle is near (``OBSTACLE_WINDOW_M``), and the
  lane ahead is free for ``FREE_HEADWAY_S`` (or ``FREE_GAP_M``), at a speed reference of at least
  ``MIN_CRUISE_SPEED_MPS``. Leaving an obstacle behind and the lane ahead becoming free count as changes
  too: the car settles again before its cruise counts. The conditions look at what the controller
  is asked to do, never at how smoothly it does it, so the cruise numbers cannot flatter it.
- for the first static obstacle: the acceleration RMS through the swerve, and how long after passing the
  car is back within 0.5 m of its lane and 1 m/s of v_ref.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

SETTLE_S = 3.0
SPEED_BAND_MPS = 0.2
LATERAL_BAND_M = 0.1
OBSTACLE_WINDOW_M = (-30.0, 60.0)
"""Not cruise from 60 m before a static obstacle until 30 m after it (road coordinate)."""
FREE_HEADWAY_S = 2.0
MIN_CRUISE_SPEED_MPS = 1.0
FREE_GAP_M = 30.0
RECOVERY_LATERAL_M = 0.5
RECOVERY_SPEED_MPS = 1.0


def add_motion_columns(trajectory: pd.DataFrame) -> pd.DataFrame:
    """``accel_mps2`` and ``jerk_mps3`` (over the step that starts at the row) and ``steer_rate_ps``."""
    if len(trajectory) < 2:
        return trajectory.assign(accel_mps2=np.nan, jerk_mps3=np.nan, steer_rate_ps=np.nan)
    dt_s = float(np.median(np.diff(trajectory["time_s"])))
    accel = np.append(np.diff(trajectory["v_mps"].to_numpy()) / dt_s, np.nan)
    jerk = np.append(np.diff(accel) / dt_s, np.nan)
    steer_rate = np.append(np.nan, np.diff(trajectory["delta"].to_numpy()) / dt_s)
    return trajectory.assign(accel_mps2=accel, jerk_mps3=jerk, steer_rate_ps=steer_rate)


def cruise_mask(trajectory: pd.DataFrame, obstacle_road_s_m: list[float]) -> np.ndarray:
    """Which rows are steady cruise (module docstring)."""
    n = len(trajectory)
    if n == 0 or "v_ref_mps" not in trajectory:
        return np.zeros(n, dtype=bool)
    time_s = trajectory["time_s"].to_numpy()
    version = trajectory["spec_version"].to_numpy()
    v_error = np.abs(trajectory["v_mps"].to_numpy() - trajectory["v_ref_mps"].to_numpy())
    offset = np.abs(trajectory["tracked_lane_offset_m"].to_numpy())
    road_s = trajectory["road_s_m"].to_numpy()
    near_obstacle = np.zeros(n, dtype=bool)
    for obstacle_s in obstacle_road_s_m:
        ahead_m = obstacle_s - road_s
        near_obstacle |= (ahead_m >= OBSTACLE_WINDOW_M[0]) & (ahead_m <= OBSTACLE_WINDOW_M[1])
    gap = trajectory["gap_ahead_m"].to_numpy() if "gap_ahead_m" in trajectory else np.full(n, np.inf)
    free = np.nan_to_num(gap, nan=np.inf) > np.maximum(FREE_GAP_M, FREE_HEADWAY_S * trajectory["v_mps"].to_numpy())
    # A new specification, an obstacle left behind or a lane that has just become free starts a manoeuvre
    # (the car returns to its lane or speeds up to v_ref): cruise again once settled.
    changed = np.r_[False, (version[1:] != version[:-1]) | (near_obstacle[:-1] & ~near_obstacle[1:])
                    | (~free[:-1] & free[1:])]
    settled = np.zeros(n, dtype=bool)
    since_s, has_settled = time_s[0], False
    for i in range(n):
        if changed[i]:
            since_s, has_settled = time_s[i], False
        if not has_settled and time_s[i] - since_s >= SETTLE_S:
            has_settled = bool(v_error[i] <= SPEED_BAND_MPS and offset[i] <= LATERAL_BAND_M)
        settled[i] = has_settled
    moving = trajectory["v_ref_mps"].to_numpy() >= MIN_CRUISE_SPEED_MPS  # holding still is not cruising
    return settled & moving & ~near_obstacle & free & (trajectory["collisions"].to_numpy() == 0)


def _rms(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return round(float(np.sqrt(np.mean(values**2))), 4) if len(values) else float("nan")


def _median(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return round(float(np.median(values)), 4) if len(values) else float("nan")


def _comfort(rows: pd.DataFrame, prefix: str) -> dict[str, Any]:
    return {
        f"{prefix}accel_rms_mps2": _rms(rows["accel_mps2"].to_numpy()),
        f"{prefix}jerk_rms_mps3": _rms(rows["jerk_mps3"].to_numpy()),
        f"{prefix}brake_fraction": round(float((rows["brake"] > 0).mean()), 4) if len(rows) else float("nan"),
        f"{prefix}steer_rate_rms": _rms(rows["steer_rate_ps"].to_numpy()),
        f"{prefix}ess_median": _median(rows["effective_samples"].to_numpy()),
        f"{prefix}ess_median_fraction": _median(rows["effective_fraction"].to_numpy())
        if "effective_fraction" in rows
        else float("nan"),
    }


def comfort_summary(trajectory: pd.DataFrame, obstacle_road_s_m: list[float]) -> dict[str, Any]:
    """The comfort and solver-health columns of ``summary.csv``; ``trajectory`` has the motion columns."""
    import pandas as pd

    if len(trajectory) == 0:  # the run failed before its first step: every column is there, all NaN
        trajectory = add_motion_columns(
            pd.DataFrame(columns=["time_s", "v_mps", "delta", "brake", "effective_samples", "effective_fraction",
                                  "tracked_lane_offset_m", "v_ref_mps", "road_s_m"], dtype=float)
        )
    cruise = cruise_mask(trajectory, obstacle_road_s_m)
    steady = trajectory[cruise]
    row = _comfort(trajectory, "")
    row["cruise_fraction"] = round(float(cruise.mean()), 4) if len(trajectory) else 0.0
    row.update(_comfort(steady, "cruise_"))
    row["cruise_lateral_rms_m"] = _rms(steady["tracked_lane_offset_m"].to_numpy()) if len(steady) else math.nan
    row["cruise_speed_error_max_mps"] = (
        round(float(np.max(np.abs(steady["v_mps"] - steady["v_ref_mps"]))), 4) if len(steady) else math.nan
    )
    row.update(obstacle_pass(trajectory, obstacle_road_s_m))
    return row


def obstacle_pass(trajectory: pd.DataFrame, obstacle_road_s_m: list[float]) -> dict[str, float]:
    """For the first static obstacle: acceleration RMS from 60 m before it until the car has recovered
    and is at least 30 m past it, and the seconds from passing it until the car is back on its lane and speed."""
    if not obstacle_road_s_m or len(trajectory) == 0:
        return {"obstacle_accel_rms_mps2": math.nan, "obstacle_recovery_s": math.nan}
    obstacle_s = min(obstacle_road_s_m)
    road_s = trajectory["road_s_m"].to_numpy()
    time_s = trajectory["time_s"].to_numpy()
    passed = np.flatnonzero(road_s >= obstacle_s)
    if len(passed) == 0:
        return {"obstacle_accel_rms_mps2": math.nan, "obstacle_recovery_s": math.nan}
    back = (np.abs(trajectory["tracked_lane_offset_m"].to_numpy()) <= RECOVERY_LATERAL_M) & (
        np.abs(trajectory["v_mps"].to_numpy() - trajectory["v_ref_mps"].to_numpy()) <= RECOVERY_SPEED_MPS
    )
    recovered = [i for i in range(passed[0], len(trajectory)) if back[i]]
    recovery_s = round(float(time_s[recovered[0]] - time_s[passed[0]]), 3) if recovered else math.nan
    end = recovered[0] if recovered else len(trajectory) - 1
    window = (road_s >= obstacle_s - OBSTACLE_WINDOW_M[1]) & (
        (np.arange(len(road_s)) <= end) | (road_s <= obstacle_s - OBSTACLE_WINDOW_M[0])
    )
    return {
        "obstacle_accel_rms_mps2": _rms(trajectory["accel_mps2"].to_numpy()[window]),
        "obstacle_recovery_s": recovery_s,
    }
