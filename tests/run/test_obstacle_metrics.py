"""Per-obstacle metrics (``obstacle_passes.csv``) and collision episodes in a run's files, in the plain world."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from agentic_mpc.scenario.runner import run_scenario
from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.world.plain_config import PlainObstacle

SCENARIO = load_scenario(Path(__file__).resolve().parents[2] / "scenarios/paper_steering_preference_plain.yaml")


def two_obstacles(variant: str, **update):
    """Scenario 1 (left-hand road: the left lane at y = +3.5) with a second obstacle, in the right lane 110 m
    ahead: the ego passes the first on the right (as asked), then the second on its left side."""
    scenario = SCENARIO.variant(variant).with_seed(3)
    obstacles = (*scenario.plain_world.obstacles, PlainObstacle(id="second", x_m=110.0, y_m=-3.5, radius_m=2.0))
    world = scenario.plain_world.model_copy(update={"obstacles": obstacles})
    outputs = scenario.outputs.model_copy(update={"plot": False, "replay": False})
    return scenario.model_copy(update={"world": world, "outputs": outputs, "duration_s": 9.0, **update})


def test_every_obstacle_gets_its_side_clearance_and_pass_time(tmp_path):
    summary = run_scenario(two_obstacles("message_right"), tmp_path)
    rows = pd.read_csv(tmp_path / "obstacle_passes.csv")
    assert list(rows.columns) == ["id", "lane_index", "road_s_m", "side", "min_clearance_m", "passed_at_s"]
    first, second = (rows.iloc[i] for i in range(2))
    assert (first["id"], first["side"], second["id"], second["side"]) == ("obstacle", "right", "second", "left")
    assert first["min_clearance_m"] > 0 and second["min_clearance_m"] > first["min_clearance_m"]
    # passed when the ego's centre reached each obstacle's x (road from x = -20, at about 15 m/s)
    assert first["road_s_m"] == pytest.approx(65.0) and second["road_s_m"] == pytest.approx(130.0)
    assert first["passed_at_s"] == pytest.approx(45.0 / 15.0, abs=0.3)
    assert second["passed_at_s"] == pytest.approx(110.0 / 15.0, abs=0.6)
    # the summary keeps its meaning: the first obstacle's side, the smallest clearance of all
    assert summary["obstacle_side"] == "right"
    assert summary["min_obstacle_clearance_m"] == pytest.approx(rows["min_clearance_m"].min(), abs=1e-4)
    assert summary["collisions"] == 0 and summary["collisions_ego_at_fault"] == 0


def test_driving_into_an_obstacle_is_one_collision_at_fault_in_events_and_summary(tmp_path):
    # Without J2 the ego keeps its lane straight into the first obstacle's circle.
    scenario = two_obstacles("no_message")
    blind = scenario.specification.model_copy(update={"obstacle_avoidance": None})
    summary = run_scenario(scenario.model_copy(update={"specification": blind, "duration_s": 5.0}), tmp_path)
    assert summary["collisions"] == 1 and summary["collisions_ego_at_fault"] == 1
    assert summary["obstacle_side"] == "hit"
    events = pd.read_csv(tmp_path / "events.csv")
    (collision,) = events[events["event"] == "collision"].itertuples()
    result = json.loads(collision.result)
    assert (result["other"], result["cause"], result["ego_at_fault"]) == ("obstacle", "ego_into_stopped", True)
    assert collision.source == "geometry" and "ego_into_stopped" in collision.content
    # the ego's centre enters the 2 m circle at x = 43 (15 m/s): one event, though in contact for many steps
    assert collision.sim_time_s == pytest.approx(43.0 / 15.0, abs=0.2)
    trajectory = pd.read_csv(tmp_path / "trajectory.csv")
    assert trajectory["collisions"].sum() > 3 and trajectory["time_s"].iloc[-1] == pytest.approx(5.0 - 0.04)
    rows = pd.read_csv(tmp_path / "obstacle_passes.csv")  # 5 s: the second one (x = 110) not reached
    assert list(rows["side"]) == ["hit", "none"] and rows["min_clearance_m"].iloc[0] < 0
    assert rows["passed_at_s"].iloc[0] > 0 and rows["passed_at_s"].isna().iloc[1]
