"""One scenario run in real SUMO with the real agent: files, metrics, reproducibility, failures."""

from pathlib import Path

import pandas as pd
import pytest

from agentic_mpc.run.files import TIMING_COLUMNS
from agentic_mpc.scenario.runner import run_scenario
from agentic_mpc.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[2]
STEERING = REPO / "scenarios/paper_steering_preference.yaml"


def short(variant: str, seed: int, **update):
    scenario = load_scenario(STEERING).variant(variant).with_seed(seed)
    return scenario.model_copy(update={"duration_s": 9.0, **update})


def test_a_run_writes_every_file_and_the_agent_decides_the_side(tmp_path):
    summary = run_scenario(short("message_right", 7), tmp_path)
    for name in ("trajectory.csv", "events.csv", "traffic.csv", "summary.csv", "transcript.jsonl", "trajectory.png",
                 "scenario.json", "obstacles.csv"):
        assert (tmp_path / name).is_file(), name
    assert summary["status"] == "ok" and summary["collisions"] == 0
    assert summary["obstacle_side"] == "right" and summary["min_obstacle_clearance_m"] > 0
    assert summary["agent_tool_calls"] == 1
    events = pd.read_csv(tmp_path / "events.csv")
    call = events[events["event"] == "tool_call"].iloc[0]
    assert call["tool"] == "set_preferred_steering_direction" and '"right"' in call["arguments"]
    assert call["apply_at_s"] == pytest.approx(0.2 + 0.5)  # lockstep: message time + latency
    trajectory = pd.read_csv(tmp_path / "trajectory.csv")
    assert trajectory["time_s"].iloc[0] <= 0.1 and trajectory["time_s"].iloc[-1] >= 8.9  # one row per step
    before = trajectory[trajectory["time_s"] < 0.7]["spec_summary"].unique()
    after = trajectory[trajectory["time_s"] > 0.7]["spec_summary"].unique()
    assert all("preferred_steering_direction" not in s for s in before)
    assert all("preferred_steering_direction(direction=right)" in s for s in after)
    assert pd.read_csv(tmp_path / "summary.csv").iloc[0]["obstacle_side"] == "right"


def test_same_seed_same_csv_in_lockstep(tmp_path):
    tables = []
    for copy in ("a", "b"):
        run_scenario(short("message_left", 11), tmp_path / copy)
        trajectory = pd.read_csv(tmp_path / copy / "trajectory.csv")
        summary = pd.read_csv(tmp_path / copy / "summary.csv")
        tables.append((trajectory.drop(columns=[c for c in TIMING_COLUMNS if c in trajectory]),
                       summary.drop(columns=[c for c in TIMING_COLUMNS if c in summary])))
    pd.testing.assert_frame_equal(tables[0][0], tables[1][0])
    pd.testing.assert_frame_equal(tables[0][1], tables[1][1])
    other = pd.read_csv(tmp_path / "a" / "trajectory.csv")
    run_scenario(short("message_left", 12), tmp_path / "c")
    assert not other["y_m"].equals(pd.read_csv(tmp_path / "c" / "trajectory.csv")["y_m"])


def test_a_failure_mid_run_keeps_what_was_recorded(tmp_path):
    scenario = short("no_message", 3)
    from agentic_mpc.sumo.world import SumoWorld

    original = SumoWorld.advance
    calls = {"n": 0}

    def failing_advance(self, *inputs):
        calls["n"] += 1
        if calls["n"] == 40:
            self.bridge.remove_vehicle(self.config.ego_id)  # SUMO loses the ego: the next command fails for real
        return original(self, *inputs)

    SumoWorld.advance = failing_advance
    try:
        with pytest.raises(Exception, match="ego"):
            run_scenario(scenario, tmp_path)
    finally:
        SumoWorld.advance = original
    trajectory = pd.read_csv(tmp_path / "trajectory.csv")
    summary = pd.read_csv(tmp_path / "summary.csv").iloc[0]
    assert 35 <= len(trajectory) <= 40
    assert summary["status"] == "failed" and "ego" in summary["error"]


def test_agent_settings_reach_the_agent():
    from agentic_mpc.scenario.runner import build_loop, build_world

    scenario = load_scenario(REPO / "scenarios/paper_steering_preference_plain.yaml").variant("message_left")
    agent = scenario.agent.model_copy(update={"restore_reminder": True, "max_rounds_per_step": 3})
    scenario = scenario.model_copy(update={"agent": agent})
    loop = build_loop(scenario, build_world(scenario))
    try:
        assert loop.agent.config.restore_reminder is True and loop.agent.config.max_rounds_per_step == 3
    finally:
        loop.close()
