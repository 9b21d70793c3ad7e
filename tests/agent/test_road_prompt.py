"""The road in the agent's system message: read over MCP from ``sumo://road`` (handedness, lanes, the edge
lane, the speed limit, what yielding and resuming mean); nothing about it from a server without the resource."""

from __future__ import annotations

import json

import pytest
from mcp.server.mcpserver import MCPServer

from agentic_mpc.agent import Agent
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.prompt import describe_road, system_prompt
from agentic_mpc.mcp.protocol import INITIAL_SPECIFICATION_URI
from agentic_mpc.world.plain_config import PlainRoad
from tests.agent.conftest import paper_start_config, plain_loop


@pytest.mark.parametrize("lefthand, edge, far", [(True, "left", "right"), (False, "right", "left")])
def test_the_system_message_states_the_road(lefthand, edge, far):
    keep = edge
    config = paper_start_config().model_copy(update={"road": PlainRoad(lefthand=lefthand)})
    with plain_loop(config) as loop, Agent(RulesBackend(yield_lane=edge), loop.server) as agent:
        system = agent.history.messages[0]
        report = agent.deliver("An ambulance is coming behind us. We'd better let them pass.").result(10)
    text = system.content
    assert f"The road: {keep}-hand traffic (vehicles keep to the {keep}); speed limit 25 m/s (90 km/h)." in text
    assert f"- {edge} lane (index 0, run_{edge}_lane): edge lane" in text
    assert f"- {far} lane (index 2, run_{far}_lane): overtaking lane" in text
    assert f"The edge lane is the {edge} lane." in text
    road = system.data["road"]
    assert road["yield"] in text and f"run_{edge}_lane(v_ref=0)" in road["yield"]
    assert road["resume"] in text and "run_center_lane(v_ref=15)" in road["resume"]
    # the initial specification and the tools are stated as before; the road comes last
    assert text.index("Initially attached primitives") < text.index("Available tools:") < text.index("The road:")
    assert "path_tracking (J1): lane=center, v_ref_mps=15.0" in text
    assert road["edge_lane"] == edge and system.data["initial_specification"] is not None
    # the rules backend is unchanged: it yields to the lane it was given
    assert report.applied_calls == [{"tool": f"run_{edge}_lane", "arguments": {"v_ref": 0}}]


def _older_server() -> MCPServer:
    """A server without ``sumo://road``: one tool and the initial specification."""
    server = MCPServer("older")

    @server.tool()
    def run_left_lane(v_ref: float) -> str:
        return json.dumps({"attached": [{"kind": "path_tracking", "lane": "left", "v_ref_mps": v_ref}]})

    @server.resource(INITIAL_SPECIFICATION_URI, mime_type="application/json")
    def initial() -> str:
        return json.dumps({"attached": [{"kind": "path_tracking", "symbol": "J1", "lane": "center",
                                         "v_ref_mps": 15.0}]})

    return server


def test_a_server_without_the_road_resource_gives_a_prompt_without_the_road():
    with Agent(RulesBackend(), _older_server()) as agent:
        system = agent.history.messages[0]
        report = agent.deliver("An ambulance is coming behind us. We'd better let them pass.").result(10)
    assert "The road" not in system.content and "traffic" not in system.content
    assert "emergency vehicle" not in system.content and "edge lane" not in system.content
    assert "path_tracking (J1): lane=center, v_ref_mps=15.0" in system.content
    assert system.data["road"] is None
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]


def test_without_a_road_the_prompt_is_what_it_was():
    assert system_prompt(None, ()) == system_prompt(None, (), road=None)
    assert "The road" not in system_prompt(None, ())


@pytest.mark.parametrize("road", [None, "left", [], {}, {"lanes": "left"}, {"lanes": [1, {"name": ""}, None]},
                                  {"lanes": [{"name": 3}], "traffic": 5, "speed_limit_mps": "fast"}])
def test_a_road_the_agent_does_not_understand_is_left_out(road):
    assert describe_road(road) == []
    assert "The road" not in system_prompt(None, (), road=road)


def test_a_partial_road_states_what_it_has():
    lines = describe_road({"lanes": [{"name": "left", "index": True}], "speed_limit_mps": 13.9, "yield": 7})
    assert lines == ["The road: speed limit 13.9 m/s (50.04 km/h).",
                     "Lanes (by the names the tools use), from the road edge outwards:", "- left lane"]
