"""The MCP server in-process: tools with bounded schemas, JSON resources, update notifications."""

from __future__ import annotations

import asyncio
import json
import math
import os
import threading

os.environ.setdefault("OMP_NUM_THREADS", "1")

import pytest
from mcp import Client
from mcp.shared.exceptions import MCPError

from agentic_mpc.mcp.protocol import APPLY_AT_META_KEY, validate_arguments
from agentic_mpc.mcp.server import build_server
from agentic_mpc.primitives import ObstacleAvoidance, PathTracking, Specification
from agentic_mpc.run.loop import LoopSettings, RunLoop
from agentic_mpc.world.plain import PlainWorld
from agentic_mpc.world.plain_config import PlainConfig, PlainObstacle, ScriptedVehicle

TOOL_NAMES = {
    "run_center_lane",
    "run_left_lane",
    "run_right_lane",
    "set_reference_speed",
    "set_preferred_steering_direction",
    "clear_preferred_steering_direction",
    "change_lane",
    "keep_lane",
    "change_reference_speed",
    "set_following_distance",
    "change_following_distance",
    "clear_following_distance",
    "overtake",
}
RESOURCES = {
    "sumo://ego",
    "sumo://road",
    "sumo://traffic",
    "sumo://emergency-vehicles",
    "sumo://obstacles",
    "mpc://specification",
    "mpc://tactics",
    "mpc://specification/initial",
    "mpc://pool",
    "agent://memory",
}


def traffic_config(ambulance_at_s: float | None) -> PlainConfig:
    """``scenarios/plain_world_traffic.yaml``'s world: an obstacle on the centre lane 80 m ahead, a slower car in
    the right lane and (optionally) an ambulance coming up behind the ego in the centre lane."""
    vehicles = [ScriptedVehicle(id="car0", lane="right", x_m=60.0, desired_speed_mps=11.0)]
    if ambulance_at_s is not None:
        vehicles.append(ScriptedVehicle(id="ambulance0", lane="center", x_m=None, desired_speed_mps=22.0,
                                        type_id="ambulance", emergency=True, appear_at_s=ambulance_at_s))
    return PlainConfig(vehicles=tuple(vehicles),
                       obstacles=(PlainObstacle(id="obstacle0", x_m=80.0, y_m=0.0, radius_m=2.0),))


def traffic_loop(ambulance_at_s: float | None) -> RunLoop:
    world = PlainWorld(traffic_config(ambulance_at_s))
    lanes = world.lanes().lanes
    specification = Specification.of(
        PathTracking(path=lanes["center"], lane="center", v_ref_mps=15.0),
        ObstacleAvoidance(obstacles=world.obstacle_circles()),
    )
    return RunLoop(world, specification, LoopSettings(duration_s=3600.0, stop_at_goal=False))


@pytest.fixture
def loop():
    with traffic_loop(ambulance_at_s=0.0) as built:
        yield built
        built.stop.set()


@pytest.fixture
def server(loop):
    return loop.server


def run(coroutine):
    return asyncio.run(asyncio.wait_for(coroutine, 60))


async def read_json(client, uri):
    return json.loads((await client.read_resource(uri)).contents[0].text)


def test_tools_and_their_bounded_schemas(server):
    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            return {t.name: t for t in (await client.list_tools()).tools}

    tools = run(go())
    assert set(tools) == TOOL_NAMES
    for name in ("run_center_lane", "run_left_lane", "run_right_lane", "set_reference_speed"):
        schema = tools[name].input_schema
        assert schema["required"] == ["v_ref"] and schema["additionalProperties"] is False
        v_ref = schema["properties"]["v_ref"]
        assert (v_ref["type"], v_ref["minimum"], v_ref["maximum"]) == ("number", 0.0, 25.0)
    direction = tools["set_preferred_steering_direction"].input_schema["properties"]["direction"]
    assert direction["enum"] == ["left", "right"]
    assert tools["clear_preferred_steering_direction"].input_schema["properties"] == {}
    assert all(t.description for t in tools.values())


def test_resources_and_template_read_as_json(server, loop):
    for _ in range(3):
        loop.step()

    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            listed = {str(r.uri) for r in (await client.list_resources()).resources}
            templates = [t.uri_template for t in (await client.list_resource_templates()).resource_templates]
            contents = {uri: await read_json(client, uri) for uri in sorted(RESOURCES)}
            mimes = {str(r.uri): r.mime_type for r in (await client.list_resources()).resources}
            vehicle = await read_json(client, "sumo://vehicle/car0")
            ego = await read_json(client, "sumo://vehicle/ego")
            with pytest.raises(MCPError, match="no road user 'nobody'"):
                await client.read_resource("sumo://vehicle/nobody")
            return listed, templates, contents, mimes, vehicle, ego

    listed, templates, contents, mimes, vehicle, ego = run(go())
    assert listed == RESOURCES and templates == ["sumo://vehicle/{vehicle_id}"]
    assert set(mimes.values()) == {"application/json"}
    assert contents["sumo://ego"]["time_s"] == pytest.approx(0.12)
    assert contents["sumo://ego"]["ego"]["lane_role"] == "center"
    assert [v["id"] for v in contents["sumo://traffic"]["vehicles"]] == ["car0", "ambulance0"]
    assert [v["id"] for v in contents["sumo://emergency-vehicles"]["emergency_vehicles"]] == ["ambulance0"]
    obstacle = contents["sumo://obstacles"]["obstacles"][0]
    assert (obstacle["id"], obstacle["length_m"], obstacle["width_m"]) == ("obstacle0", 4.0, 4.0)  # r = 2 m
    spec = contents["mpc://specification"]
    assert spec["version"] == 0 and spec["pending"] == []
    assert [p["kind"] for p in spec["attached"]] == ["mandatory", "path_tracking", "obstacle_avoidance"]
    assert contents["mpc://specification/initial"]["attached"][1]["v_ref_mps"] == 15.0
    assert {f["kind"] for f in contents["mpc://pool"]["pool"]} >= {
        "mandatory", "path_tracking", "obstacle_avoidance", "preferred_steering_direction"
    }
    assert vehicle["vehicle"]["lane_role"] == "right" and ego["vehicle"]["id"] == "ego"
    assert contents["mpc://tactics"] == {"rules": [], "active": None}  # the plain world offers no tactics
    assert contents["agent://memory"] == {"profile": None, "entries": []}  # no agent, no memory


def test_a_tool_call_changes_the_specification(server, loop):
    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            result = await client.call_tool("run_left_lane", {"v_ref": 0})
            spec = await read_json(client, "mpc://specification")
            return result, spec

    result, spec = run(go())
    assert not result.is_error
    assert result.structured_content["attached"][1]["lane"] == "left"
    assert json.loads(result.content[0].text)["version"] == 1
    assert spec["version"] == 1 and spec["summary"].startswith("path_tracking(lane=left, v_ref_mps=0)")
    assert loop.slot.current.get("path_tracking").lane == "left"


@pytest.mark.parametrize(
    ("tool", "arguments", "message"),
    [
        ("run_left_lane", {"v_ref": 30}, "greater than the maximum"),
        ("run_left_lane", {"v_ref": -0.1}, "less than the minimum"),
        ("set_reference_speed", {"v_ref": "12"}, "is not of type 'number'"),
        ("run_center_lane", {"v_ref": True}, "is not of type 'number'"),
        ("run_center_lane", {}, "'v_ref' is a required property"),
        ("run_center_lane", {"v_ref": 10, "lane": "left"}, "'lane' was unexpected"),
        ("set_preferred_steering_direction", {"direction": "up"}, "is not one of"),
        ("clear_preferred_steering_direction", {"now": True}, "'now' was unexpected"),
        ("fly", {}, "Unknown tool"),
    ],
)
def test_invalid_calls_are_mcp_errors_and_change_nothing(server, loop, tool, arguments, message):
    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            return await client.call_tool(tool, arguments)

    before = loop.slot.current
    result = run(go())
    assert result.is_error and message in result.content[0].text
    assert loop.slot.current is before and loop.slot.version == 0


def test_non_finite_numbers_are_refused_before_any_tool_runs():
    schema = {"type": "object", "properties": {"v_ref": {"type": "number", "maximum": 25}}}
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError, match="not a finite number"):
            validate_arguments("run_center_lane", schema, {"v_ref": bad})


def test_scheduled_calls_through_meta(server, loop):
    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            result = await client.call_tool("set_preferred_steering_direction", {"direction": "right"},
                                            meta={APPLY_AT_META_KEY: 0.2})
            spec = await read_json(client, "mpc://specification")
            bad = await client.call_tool("run_left_lane", {"v_ref": 5}, meta={APPLY_AT_META_KEY: "soon"})
            return result, spec, bad

    result, spec, bad = run(go())
    assert result.structured_content["apply_at_s"] == 0.2 and not result.structured_content["applied"]
    assert spec["pending"] == [{"apply_at_s": 0.2, "tool": "set_preferred_steering_direction",
                                "arguments": {"direction": "right"}}]
    assert bad.is_error and APPLY_AT_META_KEY in bad.content[0].text
    assert "preferred_steering_direction" not in loop.slot.current
    for _ in range(6):  # t = 0 .. 0.2
        loop.step()
    assert loop.slot.current.get("preferred_steering_direction").direction == "right"


def test_listeners_get_updates_as_the_simulation_advances_and_when_the_spec_changes(server, loop):
    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            seen: list[str] = []
            times: list[float] = []
            async with client.listen(resource_subscriptions=["sumo://traffic", "mpc://specification"]) as sub:
                driving = threading.Thread(target=loop.run, daemon=True)  # as fast as it goes, in its own thread
                driving.start()
                async for event in sub:
                    seen.append(event.uri)
                    if event.uri == "sumo://traffic":
                        times.append((await read_json(client, "sumo://traffic"))["time_s"])
                        if len(times) == 3:
                            await client.call_tool("run_right_lane", {"v_ref": 10})
                    if "mpc://specification" in seen and len(times) >= 4:
                        break
            loop.stop.set()
            driving.join(10)
            return seen, times

    seen, times = run(go())
    assert "mpc://specification" in seen
    assert times == sorted(times) and times[-1] > times[0]  # the reads followed the simulation


def test_a_broken_observation_still_reads_as_strict_json():
    loop = traffic_loop(ambulance_at_s=None)
    broken = {"time_s": math.nan, "ego": {"id": "ego", "x_m": math.inf}, "traffic": [], "emergency_vehicles": [],
              "obstacles": [], "collisions": []}
    server = build_server(loop.tools, lambda: broken)

    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            return (await client.read_resource("sumo://ego")).contents[0].text

    text = run(go())
    assert json.loads(text) == {"time_s": None, "ego": {"id": "ego", "x_m": None}, "collisions": []}
