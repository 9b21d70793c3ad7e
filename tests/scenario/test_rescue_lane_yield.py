"""Scenario 2 against a wall of SUMO drivers that form a rescue lane (issue 11): the ego that moves over and
keeps rolling costs the ambulance at most a third of what holding the lane costs; stopping costs more, as
SUMO's bluelight device slows an emergency vehicle to 20 km/h past a car standing beside its path."""

from pathlib import Path

import pandas as pd
import pytest

from agentic_mpc.scenario.runner import run_scenario
from agentic_mpc.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[2]
WALL = REPO / "scenarios/emergency_rescue_lane.yaml"


@pytest.mark.slow  # three 20 s runs in SUMO with the sublane model: about 15 s
def test_moving_over_without_stopping_saves_the_ambulance_two_thirds(tmp_path):
    delay = {}
    for variant in ("yield", "yield_stop", "hold"):
        scenario = load_scenario(WALL).variant(variant).with_seed(0)
        summary = run_scenario(scenario.model_copy(update={"duration_s": 20.0}), tmp_path / variant)
        assert summary["status"] == "ok" and summary["collisions"] == 0, variant
        delay[variant] = summary["ambulance_delay_s"]
    calls = pd.read_csv(tmp_path / "yield" / "events.csv").query("event == 'tool_call'")
    assert list(calls["tool"]) == ["run_left_lane", "run_center_lane"]
    assert list(calls["arguments"]) == ['{"v_ref": 4}', '{"v_ref": 15}']
    assert delay["hold"] > 3.0  # squeezing past the holding ego
    assert delay["yield"] <= delay["hold"] / 3
    assert delay["yield_stop"] > delay["yield"] + 1.0  # the stop beside its path
