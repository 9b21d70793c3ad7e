"""Comfort and solver-health metrics on trajectories whose answers are known."""

import numpy as np
import pandas as pd
import pytest

from agentic_mpc.run.comfort import add_motion_columns, comfort_summary, cruise_mask

DT = 0.04


def trajectory(seconds: float = 20.0, **columns) -> pd.DataFrame:
    n = int(round(seconds / DT))
    time_s = DT * np.arange(n)
    frame = pd.DataFrame({
        "time_s": time_s, "v_mps": np.full(n, 15.0), "v_ref_mps": np.full(n, 15.0), "delta": np.zeros(n),
        "brake": np.zeros(n), "effective_samples": np.full(n, 25.6), "effective_fraction": np.full(n, 0.1),
        "tracked_lane_offset_m": np.zeros(n), "road_s_m": 15.0 * time_s, "spec_version": np.zeros(n, dtype=int),
        "collisions": np.zeros(n, dtype=int), "gap_ahead_m": np.full(n, np.nan),
    })
    for name, values in columns.items():
        frame[name] = values(time_s) if callable(values) else values
    return add_motion_columns(frame)


def test_a_sine_speed_has_the_textbook_acceleration_and_jerk_rms():
    amplitude, omega = 0.1, 2 * np.pi * 0.5  # 0.1 m/s at 0.5 Hz
    frame = trajectory(v_mps=lambda t: 15 + amplitude * np.sin(omega * t))
    row = comfort_summary(frame, [])
    assert row["accel_rms_mps2"] == pytest.approx(amplitude * omega / np.sqrt(2), rel=0.01)
    assert row["jerk_rms_mps3"] == pytest.approx(amplitude * omega**2 / np.sqrt(2), rel=0.02)
    assert row["brake_fraction"] == 0 and row["ess_median"] == 25.6 and row["ess_median_fraction"] == 0.1


def test_brake_fraction_and_steering_rate():
    frame = trajectory(brake=lambda t: (t % 4 < 1) * 0.2, delta=lambda t: 0.1 * t)
    row = comfort_summary(frame, [])
    assert row["brake_fraction"] == pytest.approx(0.25, abs=0.01)
    assert row["steer_rate_rms"] == pytest.approx(0.1, rel=1e-6)


def test_cruise_waits_for_the_settling_after_each_change_of_specification():
    version = lambda t: (t >= 10).astype(int)  # noqa: E731
    frame = trajectory(spec_version=version, v_mps=lambda t: np.where(t < 10, 15.0, 15.0 + 0.5 * np.exp(-(t - 10))))
    cruise = cruise_mask(frame, [])
    time_s = frame["time_s"].to_numpy()
    assert not cruise[time_s < 3.0].any()  # the start is a change too
    assert cruise[(time_s > 3.0) & (time_s < 10)].all()
    assert not cruise[(time_s >= 10) & (time_s < 13)].any()  # three seconds after the change at least
    # then until the speed error is within 0.2 m/s once: 0.5 e^-(t-10) <= 0.2 from t = 10.92, so from 13 s
    assert cruise[time_s > 13.01].all()


def test_cruise_leaves_out_obstacles_close_traffic_and_standing_still():
    frame = trajectory(gap_ahead_m=lambda t: np.where((t > 5) & (t < 6), 20.0, np.nan),
                       v_ref_mps=lambda t: np.where(t > 15, 0.0, 15.0))
    cruise = cruise_mask(frame, [120.0])  # the obstacle at 120 m is near from 60 m before until 30 m after
    time_s = frame["time_s"].to_numpy()
    assert not cruise[(time_s > 5.01) & (time_s < 6)].any()
    road_s = frame["road_s_m"].to_numpy()
    assert not cruise[(road_s >= 60) & (road_s <= 150)].any()
    assert not cruise[time_s > 15.01].any()
    assert cruise[(time_s > 3.01) & (time_s < 4)].all()


def test_the_obstacle_pass_reports_how_long_the_car_needed_to_come_back():
    # the car is 2 m off its lane while passing the obstacle at 150 m (t = 10 s) and back 1 s later
    offset = lambda t: np.where((t > 8) & (t < 11), 2.0, 0.0)  # noqa: E731
    row = comfort_summary(trajectory(tracked_lane_offset_m=offset), [150.0])
    assert row["obstacle_recovery_s"] == pytest.approx(1.0, abs=DT + 1e-9)
    assert row["obstacle_accel_rms_mps2"] == 0.0


def test_an_empty_run_gives_every_column_as_nan():
    row = comfort_summary(add_motion_columns(pd.DataFrame()), [])
    assert np.isnan(row["accel_rms_mps2"]) and np.isnan(row["cruise_lateral_rms_m"]) and row["cruise_fraction"] == 0
