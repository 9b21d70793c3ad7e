"""An ambulance comes up behind the ego as it approaches a red light (scenarios/emergency_at_signal.yaml): asked
to let it through, the agent pulls over to the edge lane and stops short of the line; the ambulance goes through
on its blue light; the ego never crosses on red and completes its route. Real SUMO, the rules backend."""

from __future__ import annotations

from pathlib import Path

import pytest

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "emergency_at_signal.yaml"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    from agentic_mpc.scenario.runner import run_to_directory

    runs = {}
    for variant in ("yield", "no_message"):
        out = tmp_path_factory.mktemp(variant)
        runs[variant] = run_to_directory(SCENARIO, variant, 0, out), out
    return runs


def test_making_way_at_a_red_light_lets_the_ambulance_through_without_crossing_on_red(runs):
    import pandas as pd

    (made_way, out), (held, _) = runs["yield"], runs["no_message"]
    for summary in (made_way, held):
        assert summary["status"] == "ok", summary["error"]
        assert summary["route_completed"] and summary["junctions_passed"] == 1
        assert summary["red_light_violations"] == 0 and summary["collisions_ego_at_fault"] == 0
    # held behind the ego until its green, the ambulance loses most of a red phase; with way made, seconds
    assert held["ambulance_delay_s"] > 30.0 and made_way["ambulance_delay_s"] < 0.4 * held["ambulance_delay_s"]
    trajectory = pd.read_csv(out / "trajectory.csv")
    traffic = pd.read_csv(out / "traffic.csv")
    ambulance = traffic[traffic.id == "ambulance"]
    alongside = ambulance[ambulance.relation != "behind"].time_s.min()  # it drew level with the ego
    at_that_time = trajectory[trajectory.time_s >= alongside].iloc[0]
    assert at_that_time.lane_role == "right" and at_that_time.v_mps < 1.0  # standing in the edge lane
    stop_line_s_m = 488.0
    assert at_that_time.road_s_m < stop_line_s_m  # short of the line: it made way without entering the junction
