"""The controller tools over a specification slot and a lane source."""

from __future__ import annotations

import math

import pytest

from agentic_mpc.geometry import LanePath
from agentic_mpc.mcp.tools import ControllerTools, ToolCallError
from agentic_mpc.primitives import (
    Circle,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
    SpecificationSlot,
)
from agentic_mpc.world.lanes import RoadLanes

LANES = {
    label: LanePath.straight((0.0, y), (500.0, y), name=label)
    for label, y in (("center", 0.0), ("left", 3.5), ("right", -3.5))
}


def make_tools(lanes=LANES, limit=20.0, template=None) -> ControllerTools:
    spec = Specification.of(
        PathTracking(path=lanes["center"], lane="center", v_ref_mps=15.0, weight=2.0),
        ObstacleAvoidance(obstacles=[Circle(x_m=40.0, y_m=0.0, radius_m=2.0)]),
    )
    return ControllerTools(SpecificationSlot(spec), lambda: RoadLanes(lanes, limit), steering_template=template)


def tracking(tools: ControllerTools) -> PathTracking:
    primitive = tools.slot.current.get("path_tracking")
    assert isinstance(primitive, PathTracking)
    return primitive


def test_run_left_lane_replaces_the_path_tracking_and_keeps_its_weights():
    tools = make_tools()
    result = tools.run_lane("left", 0)
    pt = tracking(tools)
    assert (pt.lane, pt.v_ref_mps, pt.path, pt.weight) == ("left", 0.0, LANES["left"], 2.0)
    assert tools.slot.version == 1 and result["applied"] and result["changed"]
    assert [p["kind"] for p in result["attached"]] == ["mandatory", "path_tracking", "obstacle_avoidance"]
    assert result["attached"][1]["lane"] == "left"
    # exactly one path tracking is attached
    assert sum(isinstance(p, PathTracking) for p in tools.slot.current.primitives) == 1


@pytest.mark.parametrize("lane", ["center", "left", "right"])
def test_each_lane_tool_tracks_its_lane(lane):
    tools = make_tools()
    tools.run_lane(lane, 12.5)
    assert (tracking(tools).lane, tracking(tools).v_ref_mps, tracking(tools).path) == (lane, 12.5, LANES[lane])


def test_set_reference_speed_keeps_the_current_lane():
    tools = make_tools()
    tools.run_lane("right", 10)
    tools.set_reference_speed(5)
    assert (tracking(tools).lane, tracking(tools).v_ref_mps) == ("right", 5.0)


def test_the_speed_limit_is_inclusive_and_comes_from_the_lane_source():
    tools = make_tools(limit=13.89)
    tools.run_lane("center", 13.89)
    with pytest.raises(ToolCallError, match=r"outside \[0, 13.89\]"):
        tools.run_lane("center", 13.9)


@pytest.mark.parametrize("bad", [-1, 20.5, math.nan, math.inf, "10", None, True, [10]])
def test_invalid_speeds_are_refused_and_change_nothing(bad):
    tools = make_tools()
    before = tools.slot.current
    with pytest.raises(ToolCallError, match="v_ref"):
        tools.run_lane("left", bad)
    with pytest.raises(ToolCallError, match="v_ref"):
        tools.set_reference_speed(bad)
    assert tools.slot.current is before and tools.slot.version == 0


def test_a_lane_the_road_does_not_have_is_refused():
    tools = make_tools(lanes={"center": LANES["center"], "left": LANES["left"]})
    with pytest.raises(ToolCallError, match="no right lane.*center, left"):
        tools.run_lane("right", 10)
    assert tools.slot.version == 0


def test_steering_preference_attach_replace_and_clear():
    tools = make_tools(template=PreferredSteeringDirection(direction="left", form="paper", weight=5.0))
    tools.set_preferred_steering_direction("right")
    j3 = tools.slot.current.get("preferred_steering_direction")
    assert (j3.direction, j3.form, j3.weight) == ("right", "paper", 5.0)
    tools.set_preferred_steering_direction("left")
    assert tools.slot.current.get("preferred_steering_direction").direction == "left"
    result = tools.clear_preferred_steering_direction()
    assert "preferred_steering_direction" not in tools.slot.current and result["changed"]
    again = tools.clear_preferred_steering_direction()  # clearing nothing is fine
    assert not again["changed"]


@pytest.mark.parametrize("bad", ["up", "LEFT", "", None, 1])
def test_invalid_directions_are_refused(bad):
    tools = make_tools()
    with pytest.raises(ToolCallError, match="direction"):
        tools.set_preferred_steering_direction(bad)
    assert tools.slot.version == 0


def test_scheduled_changes_apply_at_their_time_in_call_order():
    tools = make_tools()
    preview = tools.run_lane("left", 0, apply_at_s=2.0)
    assert not preview["applied"] and preview["attached"][1]["lane"] == "left"
    # the second call previews on top of the first pending one
    preview = tools.set_reference_speed(7, apply_at_s=2.0)
    assert preview["attached"][1]["lane"] == "left" and preview["attached"][1]["v_ref_mps"] == 7.0
    tools.set_preferred_steering_direction("right", apply_at_s=3.0)
    assert tracking(tools).lane == "center" and len(tools.pending()) == 3
    assert tools.apply_due(1.96) == []
    applied = tools.apply_due(2.0)
    assert [p.tool for p in applied] == ["run_left_lane", "set_reference_speed"]
    assert (tracking(tools).lane, tracking(tools).v_ref_mps) == ("left", 7.0)
    assert "preferred_steering_direction" not in tools.slot.current
    tools.apply_due(3.04)
    assert tools.slot.current.get("preferred_steering_direction").direction == "right"
    assert tools.pending() == []


def test_a_scheduled_call_with_bad_arguments_fails_at_once():
    tools = make_tools()
    with pytest.raises(ToolCallError):
        tools.run_lane("left", 99, apply_at_s=1.0)
    assert tools.pending() == []


def test_a_tuple_lane_source_works_too():
    tools = ControllerTools(make_tools().slot, lambda: (LANES, 30.0))
    tools.run_lane("left", 25)
    assert tracking(tools).v_ref_mps == 25.0
