"""``sumo://road``: the road's lanes, handedness, edge lane, speed limit and what yielding and resuming mean,
read by a real MCP client from the server the run loop builds (in process), for left- and right-hand roads."""

from __future__ import annotations

import asyncio
import json
import os
import sys
from pathlib import Path

import pytest
from mcp import Client, StdioServerParameters

from agentic_mpc.mcp import protocol
from agentic_mpc.mcp.road import describe_road
from agentic_mpc.mcp.server import build_server
from agentic_mpc.mcp.tools import ControllerTools
from agentic_mpc.primitives import PathTracking, Specification, SpecificationSlot
from agentic_mpc.run.loop import LoopSettings, RunLoop
from agentic_mpc.world.lanes import RoadLanes
from agentic_mpc.world.plain import PlainWorld
from agentic_mpc.world.plain_config import PlainConfig, PlainRoad

REPO = Path(__file__).resolve().parents[2]


def read_road(server) -> dict:
    async def go():
        async with Client(server, cache=None) as client:
            listed = {str(r.uri): r.mime_type for r in (await client.list_resources()).resources}
            assert listed[protocol.ROAD_URI] == "application/json"
            return json.loads((await client.read_resource(protocol.ROAD_URI)).contents[0].text)

    return asyncio.run(asyncio.wait_for(go(), 60))


def loop_over(lefthand: bool, speed_limit_mps: float = 25.0, lane: str = "center", v_ref: float = 15.0) -> RunLoop:
    world = PlainWorld(PlainConfig(road=PlainRoad(lefthand=lefthand, speed_limit_mps=speed_limit_mps)))
    spec = Specification.of(PathTracking(path=world.lanes().lanes[lane], lane=lane, v_ref_mps=v_ref))
    return RunLoop(world, spec, LoopSettings(duration_s=10.0, stop_at_goal=False))


@pytest.mark.parametrize("lefthand, edge, far", [(True, "left", "right"), (False, "right", "left")])
def test_the_run_loops_server_serves_the_road(lefthand, edge, far):
    with loop_over(lefthand) as loop:
        road = read_road(loop.server.mcp_server)
        world = loop.world
        indices = {name: world.lane_index_of(world.lanes().lanes[name]) for name in ("left", "center", "right")}
    keep = "left" if lefthand else "right"
    assert road["traffic"] == f"{keep}-hand" and road["lefthand"] is lefthand and road["keep_to"] == keep
    assert road["edge_lane"] == edge
    assert [lane["name"] for lane in road["lanes"]] == [edge, "center", far]  # from the road edge outwards
    assert {lane["name"]: lane["index"] for lane in road["lanes"]} == indices  # the world's (SUMO's) indices
    assert [lane["index"] for lane in road["lanes"]] == [0, 1, 2]
    assert [lane["tool"] for lane in road["lanes"]] == [f"run_{edge}_lane", "run_center_lane", f"run_{far}_lane"]
    assert "edge lane" in road["lanes"][0]["role"] and "overtaking" in road["lanes"][2]["role"]
    assert road["speed_limit_mps"] == 25.0 and road["speed_limit_kmh"] == 90.0
    assert road["yield_call"] == {"tool": f"run_{edge}_lane", "arguments": {"v_ref": 0.0}}
    assert f"run_{edge}_lane(v_ref=0)" in road["yield"] and f"{keep}-hand" in road["yield"]
    assert road["resume_call"] == {"tool": "run_center_lane", "arguments": {"v_ref": 15.0}}
    assert "initial" in road["resume"] and "run_center_lane(v_ref=15)" in road["resume"]
    assert road["summary"].startswith(f"{keep.capitalize()}-hand traffic")


def test_resume_restores_the_initial_lane_and_speed_and_the_limit_is_the_roads():
    with loop_over(True, speed_limit_mps=13.9, lane="right", v_ref=12.5) as loop:
        loop.tools.run_lane("left", 0.0)  # yielding now: resume still means the INITIAL specification
        road = read_road(loop.server.mcp_server)
    assert road["resume_call"] == {"tool": "run_right_lane", "arguments": {"v_ref": 12.5}}
    assert road["speed_limit_mps"] == 13.9 and road["speed_limit_kmh"] == pytest.approx(50.0)


def test_a_server_built_without_the_worlds_indices_counts_from_the_edge():
    world = PlainWorld(PlainConfig(road=PlainRoad(lefthand=False)))
    lanes = world.lanes().lanes
    initial = Specification.of(PathTracking(path=lanes["center"], lane="center", v_ref_mps=15.0))
    tools = ControllerTools(SpecificationSlot(initial), world.lanes)
    road = read_road(build_server(tools, lambda: {"time_s": 0.0}).mcp_server)
    assert [(lane["name"], lane["index"]) for lane in road["lanes"]] == [("right", 0), ("center", 1), ("left", 2)]


def test_roads_of_one_and_two_lanes():
    one = describe_road(RoadLanes({"center": object()}, 20.0, True))
    assert one["edge_lane"] == "center" and one["yield_call"]["tool"] == "run_center_lane"
    assert "resume_call" not in one and "initial" in one["resume"]  # no initial lane known: the sentence alone
    two = describe_road(RoadLanes({"left": object(), "right": object()}, 20.0, False), "left", 10.0,
                        lane_index=lambda path: None)  # a world that does not know: counted from the edge
    assert [(lane["name"], lane["index"]) for lane in two["lanes"]] == [("right", 0), ("left", 1)]
    assert two["edge_lane"] == "right" and "overtaking" in two["lanes"][1]["role"]
    assert two["resume_call"] == {"tool": "run_left_lane", "arguments": {"v_ref": 10.0}}
    assert json.loads(json.dumps(two)) == two


@pytest.mark.slow  # a server process: about 5 s
def test_the_road_over_stdio_from_a_left_hand_scenario():
    scenario = REPO / "scenarios" / "paper_steering_preference_plain.yaml"
    params = StdioServerParameters(
        command=sys.executable, args=["-m", "agentic_mpc", "serve", str(scenario), "--transport", "stdio"],
        cwd=str(REPO), env={**os.environ, "OMP_NUM_THREADS": "1"},
    )

    async def go():
        async with Client(params, cache=None) as client:
            return json.loads((await client.read_resource(protocol.ROAD_URI)).contents[0].text)

    road = asyncio.run(asyncio.wait_for(go(), 60))
    assert road["traffic"] == "left-hand" and road["edge_lane"] == "left"
    assert road["yield_call"] == {"tool": "run_left_lane", "arguments": {"v_ref": 0.0}}


def test_a_road_with_more_lanes_than_roles_lists_every_lane_and_its_emergency_lane():
    from agentic_mpc.geometry import LanePath

    paths = tuple(LanePath.straight((0.0, 4.0 * i), (100.0, 4.0 * i)) for i in range(4))  # index 0: the right edge
    roles = {"right": paths[0], "left": paths[3]}
    road = RoadLanes(roles, 31.29, False, paths, (3, 2, 1, 0), 0)
    described = describe_road(road, lane_index=lambda path: paths.index(path))
    assert [lane["name"] for lane in described["lanes"]] == ["right", "lane1", "lane2", "left"]
    assert [lane["tool"] for lane in described["lanes"]] == [
        "run_right_lane", "keep_lane(index=1)", "keep_lane(index=2)", "run_left_lane"]
    assert described["emergency_lane"] == "right" and "pull_over()" in described["lanes"][0]["role"]
