"""The manoeuvre tools over MCP on LaMPilot's scenes in SUMO: what they attach, and what they refuse (with
the reason, the specification unchanged)."""

from __future__ import annotations

import asyncio
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import pytest
from mcp import Client

from agentic_mpc.lampilot.dataset import load_tasks, select_cases
from agentic_mpc.lampilot.scenes import case_scenario
from agentic_mpc.scenario.runner import build_loop, build_world
from agentic_mpc.shipped import nets_dir
from tests.lampilot.tasks import write_tasks


def scene_loop(tmp_path, task: str):
    case = select_cases(load_tasks(write_tasks(tmp_path / "tasks", [task]), [task]))[0]
    scenario = case_scenario(case, {"backend": "rules"}, nets_dir())
    loop = build_loop(scenario, build_world(scenario), embedded_agent=False)
    loop.step()
    return loop


@pytest.fixture
def motorway(tmp_path):
    with scene_loop(tmp_path, "gap_abs") as loop:  # right lane of two, a leader 25-75 m ahead
        yield loop


@pytest.fixture
def shoulder_road(tmp_path):
    with scene_loop(tmp_path, "shoulder") as loop:
        yield loop


def call(loop, tool, arguments):
    async def go():
        async with Client(loop.server.mcp_server, cache=None) as client:
            names = {t.name for t in (await client.list_tools()).tools}
            return names, await client.call_tool(tool, arguments)

    return asyncio.run(asyncio.wait_for(go(), 60))


@pytest.mark.parametrize(("tool", "arguments", "message"), [
    ("change_lane", {"direction": "right"}, "no lane to the right"),
    ("change_lane", {"direction": "up"}, "is not one of"),
    ("keep_lane", {"index": 5}, "not on this road"),
    ("keep_lane", {"index": 99}, "greater than the maximum"),
    ("change_reference_speed", {"delta_v": "fast"}, "is not of type 'number'"),
    ("set_following_distance", {}, "'gap' is a required property"),
    ("set_following_distance", {"gap": 20, "change": 5}, "'change' was unexpected"),
    ("set_following_distance", {"gap": 1}, "less than the minimum"),
    ("change_following_distance", {"change": -500}, "less than the minimum"),
    ("change_following_distance", {"change": -80}, "outside [2, 200] m"),
    ("overtake", {"side": "right"}, "no lane to overtake in on the right"),
    ("overtake", {"side": "left", "afterwards": "maybe"}, "is not one of"),
    ("pull_over", {}, "Unknown tool"),  # not offered: this road has no emergency lane
])
def test_refused_calls_say_why_and_change_nothing(motorway, tool, arguments, message):
    before = motorway.slot.current
    _, result = call(motorway, tool, arguments)
    assert result.is_error and message in result.content[0].text
    assert motorway.slot.current is before


def test_change_lane_and_keep_lane_attach_j1_on_that_lane_at_the_same_speed(motorway):
    v_ref = motorway.slot.current.get("path_tracking").v_ref_mps
    names, result = call(motorway, "change_lane", {"direction": "left"})
    assert not result.is_error and "pull_over" not in names
    tracking = motorway.slot.current.get("path_tracking")
    assert (tracking.lane, tracking.v_ref_mps) == ("left", v_ref)
    call(motorway, "keep_lane", {"index": 0})  # SUMO's index: 0 is the edge (right) lane
    assert motorway.slot.current.get("path_tracking").lane == "right"


def test_a_relative_speed_is_capped_at_the_limit_and_says_so(motorway):
    _, result = call(motorway, "change_reference_speed", {"delta_v": 20})
    assert not result.is_error and "the road's limit" in result.content[0].text
    assert motorway.slot.current.get("path_tracking").v_ref_mps == pytest.approx(31.29)
    call(motorway, "change_reference_speed", {"delta_v": -50})
    assert motorway.slot.current.get("path_tracking").v_ref_mps == 0.0


def test_a_close_following_distance_attaches_j4_and_lowers_j0s_time_gap_to_match(motorway):
    _, result = call(motorway, "set_following_distance", {"gap": 15})
    assert not result.is_error
    spec = motorway.slot.current
    assert spec.get("following_distance").gap_m == 15.0
    assert 0.4 <= spec.mandatory.time_gap_s < 1.2  # J0 still attached, its time gap no longer demands 35 m
    gap_now = motorway.tools.situation().leader_gap_m
    call(motorway, "change_following_distance", {"change": 10})
    assert motorway.slot.current.get("following_distance").gap_m == pytest.approx(gap_now + 10, abs=0.01)
    call(motorway, "clear_following_distance", {})
    assert "following_distance" not in motorway.slot.current
    assert motorway.slot.current.mandatory.time_gap_s == 1.2  # the initial J0's again


def test_an_overtake_ends_with_the_lane_asked_for_once_the_car_is_passed(motorway):
    _, result = call(motorway, "overtake", {"side": "left", "afterwards": "return"})
    assert not result.is_error
    assert motorway.slot.current.get("path_tracking").lane == "left"
    passed = motorway.tools._overtake.leader_id
    for _ in range(int(60 / 0.04)):
        motorway.step()
        if motorway.slot.current.get("path_tracking").lane == "right":
            break
    situation = motorway.tools.situation()
    assert motorway.slot.current.get("path_tracking").lane == "right"  # back where it came from
    assert situation.road_s_m - situation.positions[passed][0] > 2 * situation.length_m


def test_pull_over_is_offered_with_an_emergency_lane_and_drives_to_it_at_zero(shoulder_road):
    names, result = call(shoulder_road, "pull_over", {})
    assert "pull_over" in names and not result.is_error
    tracking = shoulder_road.slot.current.get("path_tracking")
    assert tracking.v_ref_mps == 0.0 and tracking.lane == "right"  # SUMO lane 0: the emergency lane
    _, refused = call(shoulder_road, "change_lane", {"direction": "right"})
    assert refused.is_error  # from the middle lane the next one right is the emergency lane: pull_over's
