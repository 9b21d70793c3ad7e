"""Stuck is standing still while asked to move with nothing to queue behind: measured per interval, reported
as the longest, with its reason, as events, and as the end of a run where every lane is blocked."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from agentic_mpc.run.stuck import HOPELESS_S, REPORTED_S, StuckTracker
from agentic_mpc.world.observation import JunctionAhead

DT = 0.04


def observation(t, speed, *, traffic=(), obstacles=(), lane=1, road_s=100.0, junctions=()):
    """The ego at the origin heading along x, 2 m wide, its lane's centre on y = 0 (3.5 m lanes)."""
    ego = SimpleNamespace(speed_mps=speed, lane_index=lane, road_s_m=road_s, x_m=0.0, y_m=0.0, heading_rad=0.0,
                          width_m=2.0)
    return SimpleNamespace(time_s=t, ego=ego, traffic=tuple(traffic), obstacles=tuple(obstacles),
                           junctions_ahead=tuple(junctions))


def test_standing_at_a_red_light_or_giving_way_is_waiting_not_stuck():
    def junction(distance, signal, must_yield=False):
        return JunctionAhead("J", 110.0, 130.0, distance, "straight", signal, must_yield, False, None)

    for ahead in (junction(4.0, "red"), junction(4.0, "yellow"), junction(3.0, None, must_yield=True)):
        tracker = StuckTracker()
        for step in range(200):
            tracker.update(observation(step * 0.04, 0.0, junctions=[ahead]), v_ref_mps=13.0)
        tracker.finish()
        assert tracker.longest_s == 0.0, ahead
    tracker = StuckTracker()  # green, or far from the line: standing there is stuck
    for step in range(200):
        tracker.update(observation(step * 0.04, 0.0, junctions=[junction(40.0, "red")]), v_ref_mps=13.0)
    tracker.finish()
    assert tracker.longest_s == pytest.approx(8.0)


def car(gap, lane_offset=0, relation="ahead", lateral_m=0.0):
    """A 4.5 x 1.8 m car ``gap`` m ahead of the 5.2 m ego, ``lateral_m`` left of its lane's centre."""
    return SimpleNamespace(id="car", relative_lane=lane_offset, relation=relation, gap_m=gap, x_m=gap + 4.85,
                           y_m=3.5 * lane_offset + lateral_m, width_m=1.8)


def obstacle(identifier, gap, lane=1, road_s=105.0):
    return SimpleNamespace(id=identifier, relation="ahead", lane_index=lane, gap_m=gap, road_s_m=road_s)


def drive(tracker, seconds, v_ref=15.0, start=0.0, **scene):
    steps = round(seconds / DT)
    for k in range(steps):
        tracker.update(observation(start + k * DT, **scene), v_ref)
    return start + steps * DT


def test_standing_with_the_road_ahead_free_is_stuck_and_reported():
    tracker = StuckTracker(lane_count=3)
    t = drive(tracker, 1.0, speed=10.0)
    t = drive(tracker, 5.0, speed=0.0, start=t)
    drive(tracker, 1.0, speed=3.0, start=t)
    tracker.finish()
    assert tracker.longest_s == pytest.approx(5.0, abs=DT)
    assert tracker.longest_reason == "road ahead free"
    (event,) = tracker.events()
    assert event["event"] == "stuck" and event["sim_time_s"] == pytest.approx(1.0)
    assert "stood still for 5.0 s" in event["content"]


def test_queueing_behind_a_car_or_being_told_to_stop_is_not_stuck():
    tracker = StuckTracker(lane_count=3)
    t = drive(tracker, 6.0, speed=0.0, traffic=[car(3.0)])  # a queue: it will move
    drive(tracker, 6.0, speed=0.0, v_ref=0.0, start=t)  # the specification asks it to stand
    tracker.finish()
    assert tracker.longest_s == 0.0 and tracker.events() == []


def test_a_car_in_the_next_lane_or_far_ahead_is_no_queue():
    tracker = StuckTracker(lane_count=3)
    drive(tracker, 3.0, speed=0.0, traffic=[car(3.0, lane_offset=1), car(30.0)])
    tracker.finish()
    assert tracker.longest_s == pytest.approx(3.0, abs=DT) and tracker.longest_reason == "road ahead free"


def test_a_car_in_the_next_lane_overlapping_the_egos_path_is_a_queue():
    """The ego astride the line to the left lane, counted in it, with a car 0.5 m ahead in the centre lane whose body
    overlaps its path (4017, a gridlock at the curve's stopped car): queueing. One clear of its path is not."""
    tracker = StuckTracker(lane_count=3)
    t = drive(tracker, 3.0, speed=0.0, traffic=[car(0.5, lane_offset=-1, lateral_m=2.4)])  # 1.1 m right of the ego
    tracker.finish()
    assert tracker.longest_s == 0.0
    tracker = StuckTracker(lane_count=3)
    drive(tracker, 3.0, speed=0.0, start=t, traffic=[car(0.5, lane_offset=-1, lateral_m=1.5)])  # 2.0 m right
    tracker.finish()
    assert tracker.longest_s == pytest.approx(3.0, abs=DT) and tracker.longest_reason == "road ahead free"


def test_standing_behind_a_stopped_car_is_stuck_and_short_waits_are_not_events():
    tracker = StuckTracker(lane_count=3)
    t = drive(tracker, REPORTED_S / 2, speed=0.0, obstacles=[obstacle("stopped", 0.5)])
    t = drive(tracker, 1.0, speed=5.0, start=t)
    drive(tracker, 3.0, speed=0.0, obstacles=[obstacle("stopped", 0.5)], start=t)
    tracker.finish()
    assert [round(i.duration_s, 2) for i in tracker.intervals] == [pytest.approx(REPORTED_S / 2, abs=DT),
                                                                   pytest.approx(3.0, abs=DT)]
    assert tracker.longest_reason == "behind obstacle stopped" and len(tracker.events()) == 1


def test_every_lane_blocked_is_said_and_ends_the_run():
    tracker = StuckTracker(lane_count=3)
    wall = [obstacle("a", 1.0, lane=0), obstacle("b", 1.0, lane=1, road_s=110.0), obstacle("c", 1.0, lane=2)]
    drive(tracker, HOPELESS_S - 1.0, speed=0.0, obstacles=wall)
    assert not tracker.hopeless
    drive(tracker, 1.5, speed=0.0, obstacles=wall, start=HOPELESS_S - 1.0)
    assert tracker.hopeless
    tracker.finish()
    assert tracker.longest_reason == "every lane blocked (a, b, c)"
    two_of_three = StuckTracker(lane_count=3)
    drive(two_of_three, HOPELESS_S + 1.0, speed=0.0, obstacles=wall[:2])
    assert not two_of_three.hopeless  # a lane is open: stuck, but not hopeless


def test_a_road_blocked_in_every_lane_ends_the_sumo_run_with_the_reason(tmp_path):
    """Closed loop in SUMO: three stopped cars abreast; the run ends 10 s after the ego stood, not at 120 s."""
    import csv
    from pathlib import Path

    from agentic_mpc.scenario.runner import run_scenario
    from agentic_mpc.scenario.schema import load_scenario

    nets = Path(__file__).resolve().parents[2] / "sumo_nets"
    file = tmp_path / "wall.yaml"
    file.write_text(f"""name: wall
simulation:
  net_file: {nets / 'straight.net.xml'}
  route_files: [{nets / 'straight.rou.xml'}]
  road: straight
  ego: {{lane: center, pos_m: 30.0, speed_mps: 10.0}}
  obstacles:
    - {{id: block_left, lane: left, pos_m: 120.0}}
    - {{id: block_centre, lane: center, pos_m: 120.0}}
    - {{id: block_right, lane: right, pos_m: 120.0}}
specification:
  path_tracking: {{lane: center, v_ref_mps: 10.0}}
  obstacle_avoidance: {{}}
duration_s: 120.0
outputs: {{plot: false, replay: false}}
""")
    summary = run_scenario(load_scenario(file).base, tmp_path / "run")
    assert summary["status"] == "ok" and summary["sim_time_s"] < 40.0 and summary["collisions"] == 0
    assert summary["stuck_reason"] == "every lane blocked (block_centre, block_left, block_right)"
    assert summary["stuck_s"] == pytest.approx(HOPELESS_S, abs=0.1) and summary["blockages_passed"] == 0
    with (tmp_path / "run" / "events.csv").open() as events:
        assert [row["event"] for row in csv.DictReader(events)].count("stuck") == 1


def test_resume_to_v_ref_counts_from_the_last_resume_to_back_at_speed():
    from agentic_mpc.run.stuck import resume_to_v_ref_s

    t = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 18.0]
    v_ref = [15.0, 0.0, 0.0, 15.0, 15.0, 15.0, 15.0, 15.0]
    assert resume_to_v_ref_s(t, [15.0, 8.0, 0.0, 0.0, 9.0, 14.6, 15.0, 15.0], v_ref) == 2.0  # 14.6: within 0.5
    assert resume_to_v_ref_s(t, [15.0, 8.0, 0.0, 0.0, 2.0, 5.0, 9.0, 9.0], v_ref) == float("inf")  # 15 s on
    # the run ended 3 s after the resume, short of v_ref: undecided (NaN), not a miss
    assert math.isnan(resume_to_v_ref_s(t[:-1], [15.0, 8.0, 0.0, 0.0, 2.0, 5.0, 9.0], v_ref[:-1]))
    assert math.isnan(resume_to_v_ref_s(t, [15.0] * 8, [15.0] * 8))  # no resume


def test_giving_way_at_a_waiting_point_inside_the_junction_is_waiting_not_stuck():
    """The ego's front 1 m before a left turn's waiting point, 8 m past the line, giving way to oncoming traffic."""
    inside = JunctionAhead("J", 110.0, 134.0, -7.0, "left", "green", True, False, None, 118.0, 2.0)
    tracker = StuckTracker()
    for step in range(200):
        tracker.update(observation(step * 0.04, 0.0, junctions=[inside]), v_ref_mps=13.0)
    tracker.finish()
    assert tracker.longest_s == 0.0
