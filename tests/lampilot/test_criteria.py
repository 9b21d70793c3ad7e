"""LaMPilot's success criteria and driving score on hand-made step views."""

import math

import pytest

from agentic_mpc.lampilot.criteria import Judge, StepView


def view(t, speed=25.0, lane=1, **kwargs):
    fields = dict(shoulder=None, heading_error_deg=0.0, off_road=False, collided=False, road_s_m=100.0 + 25.0 * t)
    fields.update(kwargs)
    return StepView(t, speed, lane, **fields)


def run(judge, views):
    for v in views:
        verdict = judge.update(v)
        if verdict is not None:
            return verdict
    return None


def test_a_speed_must_be_held_within_1_mps_for_5_s():
    judge = Judge({"type": "ACCEvalbySpeed", "rel_speed": -5}, view(0.0, speed=30.0))
    assert judge.target == 25.0
    views = [view(0.1 * k, speed=30.0 - min(5.5, 0.5 * 0.1 * k)) for k in range(800)]
    verdict = run(judge, views)
    assert verdict.success and verdict.time_s == pytest.approx(8.0 + 5.0, abs=0.11)  # within 1 m/s from 8 s, held 5 s
    assert 0 < judge.scores()["score"] <= 100


def test_a_slower_leader_within_100_m_sets_the_speed_to_hold():
    judge = Judge({"type": "ACCEvalbySpeed", "speed": 30}, view(0.0))
    views = [view(0.1 * k, speed=22.0, leader_id="car0", leader_gap_m=40.0, leader_speed_mps=22.5) for k in range(60)]
    assert run(judge, views).success


def test_a_gap_within_30_percent_held_for_5_s_and_no_leader_fails_at_once():
    first = view(0.0, leader_id="car0", leader_gap_m=50.0, leader_speed_mps=25.0)
    judge = Judge({"type": "ACCEvalbyDistance", "rel_distance": -15}, first)
    assert judge.target == 35.0
    ok = [view(0.1 * k, leader_id="car0", leader_gap_m=50.0 if k < 30 else 40.0, leader_speed_mps=25.0) for k in range(200)]
    verdict = run(judge, ok)
    assert verdict.success and verdict.time_s == pytest.approx(8.0, abs=0.11)
    lonely = Judge({"type": "ACCEvalbyDistance", "distance": 20}, view(0.0))
    assert run(lonely, [view(0.0)]).reason == "no leader within 100 m at the command"


def test_lane_change_needs_the_adjacent_lane_and_a_straight_heading():
    judge = Judge({"type": "LaneChangeEval", "direction": "left"}, view(0.0, lane=1))
    assert judge.update(view(1.0, lane=0, heading_error_deg=8.0)) is None
    assert judge.update(view(1.5, lane=0, heading_error_deg=3.0)).success


def test_an_overtake_needs_two_car_lengths_past_the_leader_in_the_side_lane():
    judge = Judge({"type": "OvertakeEval", "direction": "left"}, view(0.0, lane=1, leader_id="car0", leader_gap_m=20.0))
    assert judge.update(view(1.0, lane=0, positions={"car0": 100.0 + 25.0 - 5.0})) is None
    assert judge.update(view(2.0, lane=0, positions={"car0": 100.0 + 50.0 - 10.5})).success


def test_pull_over_collision_off_road_and_time_limit():
    shoulder = dict(shoulder=2)
    judge = Judge({"type": "PullOverEval"}, view(0.0, **shoulder))
    assert judge.update(view(5.0, lane=2, speed=0.4, **shoulder)).success
    crash = Judge({"type": "PullOverEval"}, view(0.0, **shoulder))
    assert crash.update(view(1.0, collided=True, **shoulder)).reason == "collision"
    assert crash.scores()["score"] == 0.0
    off = Judge({"type": "LaneChangeEval", "direction": "right"}, view(0.0))
    assert off.update(view(1.0, lane=None, off_road=True)).reason == "left the road"
    late = Judge({"type": "LaneChangeEval", "direction": "right"}, view(0.0))
    assert late.update(view(60.0)).reason == "not met within 60 s"


def test_the_driving_score_weights_ttc_speed_variance_and_time():
    judge = Judge({"type": "LaneChangeEval", "direction": "left"}, view(0.0))
    judge.update(view(0.0, speed=20.0, leader_gap_m=10.0, leader_speed_mps=10.0))  # TTC 1 s
    judge.update(view(6.0, lane=0, speed=20.0))
    scores = judge.scores()
    assert scores["ttc_score"] == pytest.approx(99.0)  # 100 - 1 / min TTC
    assert scores["speed_variance_score"] == pytest.approx(100.0)
    assert scores["time_efficiency_score"] == pytest.approx(90.0)
    assert scores["score"] == pytest.approx(0.5 * 99.0 + 0.3 * 100.0 + 0.2 * 90.0)
    assert math.isinf(view(0.0).time_to_collision_s)
