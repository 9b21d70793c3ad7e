"""The client contract (agentic_mpc.mcp.protocol): the agent needs it and nothing of the server's implementation."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from agentic_mpc.mcp import protocol
from agentic_mpc.mcp.tools import ControllerTools
from agentic_mpc.primitives import PathTracking, Specification, SpecificationSlot
from agentic_mpc.world.plain import PlainWorld

REPO = Path(__file__).resolve().parents[2]


def run_python(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120, check=False
    )


def test_the_agent_imports_nothing_of_the_server():
    code = (
        "import agentic_mpc.mcp.protocol, agentic_mpc.agent.agent; import sys; "
        "assert 'agentic_mpc.mcp.server' not in sys.modules"
    )
    result = run_python(code)
    assert result.returncode == 0, result.stderr


def test_the_protocol_imports_neither_the_sdk_nor_the_tools():
    code = (
        "import agentic_mpc.mcp.protocol; import sys; "
        "loaded = sorted(m for m in sys.modules if m == 'mcp' or m.startswith('mcp.') or m in "
        "('agentic_mpc.mcp.server', 'agentic_mpc.mcp.tools', 'jsonschema')); "
        "assert not loaded, loaded"
    )
    result = run_python(code)
    assert result.returncode == 0, result.stderr


def test_the_uris_are_the_wire_contract():
    assert protocol.OBSERVATION_URIS == (
        "sumo://ego",
        "sumo://traffic",
        "sumo://emergency-vehicles",
        "sumo://obstacles",
    )
    assert (protocol.EGO_URI, protocol.TRAFFIC_URI) == ("sumo://ego", "sumo://traffic")
    assert (protocol.EMERGENCY_VEHICLES_URI, protocol.OBSTACLES_URI) == (
        "sumo://emergency-vehicles",
        "sumo://obstacles",
    )
    assert protocol.VEHICLE_URI_TEMPLATE == "sumo://vehicle/{vehicle_id}"
    assert protocol.SPECIFICATION_URI == "mpc://specification"
    assert protocol.INITIAL_SPECIFICATION_URI == "mpc://specification/initial"
    assert protocol.POOL_URI == "mpc://pool"
    assert protocol.APPLY_AT_META_KEY == "agentic-mpc/apply_at_s"


def make_server():
    from agentic_mpc.mcp.server import build_server

    world = PlainWorld()
    lanes = world.lanes().lanes
    # the paper's initial specification; no obstacles, so no obstacle avoidance
    specification = Specification.of(PathTracking(path=lanes["center"], lane="center", v_ref_mps=15.0))
    tools = ControllerTools(SpecificationSlot(specification), world.lanes)
    return build_server(tools, lambda: {"time_s": 0.0, "ego": {"id": "ego"}, "traffic": []})


def test_the_server_registers_exactly_the_protocol_uris():
    from mcp import Client

    server = make_server()
    assert server.mcp_server is server.server

    async def listing():
        async with Client(server.mcp_server, cache=None) as client:
            resources = {str(r.uri) for r in (await client.list_resources()).resources}
            templates = [t.uri_template for t in (await client.list_resource_templates()).resource_templates]
            return resources, templates

    resources, templates = asyncio.run(asyncio.wait_for(listing(), 60))
    expected = {
        *protocol.OBSERVATION_URIS,
        protocol.SPECIFICATION_URI,
        protocol.INITIAL_SPECIFICATION_URI,
        protocol.POOL_URI,
        protocol.TACTICS_URI,
        protocol.ROAD_URI,
        protocol.MEMORY_URI,
    }
    assert resources == expected
    assert templates == [protocol.VEHICLE_URI_TEMPLATE]


@pytest.mark.parametrize(
    "wrap", [lambda s: s, lambda s: s.mcp_server, lambda s: SimpleNamespace(mcp_server=s.mcp_server)]
)
def test_the_agent_takes_the_sdk_server_or_anything_exposing_mcp_server(wrap):
    from agentic_mpc.agent import Agent
    from agentic_mpc.agent.backends.rules import RulesBackend

    server = make_server()
    agent = Agent(RulesBackend(), wrap(server))
    assert agent.server is server.mcp_server
    with agent:
        assert {t.name for t in agent.tools} >= {"run_left_lane", "set_reference_speed"}
        assert agent.history.messages[0].data["initial_specification"]["attached"]
