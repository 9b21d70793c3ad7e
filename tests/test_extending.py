"""Extending the package through its one registration each (docs/architecture.md, "where a newcomer goes"):
a toy tool, a toy world and a toy backend, defined here and driven end to end: a tool call over MCP, a short
run in the toy world, an ``ask`` answered by the toy backend."""

from __future__ import annotations

import asyncio
import json
from typing import Annotated, Any, Literal

import pytest
from mcp import Client
from mcp.shared.exceptions import MCPError
from pydantic import Field

from agentic_mpc import cli
from agentic_mpc.agent.backends.base import BackendReply
from agentic_mpc.agent.messages import ToolCall
from agentic_mpc.agent.settings import AgentRunSettings, register_backend, unregister_backend
from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.mcp.protocol import ToolName
from agentic_mpc.mcp.server import build_server
from agentic_mpc.mcp.tool_table import TABLE, tool
from agentic_mpc.mcp.tools import ControllerTools
from agentic_mpc.primitives import PathTracking, Specification, SpecificationSlot
from agentic_mpc.scenario.runner import run_scenario
from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.world.plain import PlainWorld
from agentic_mpc.world.plain_config import PlainConfig, PlainRoad
from agentic_mpc.worlds import WorldKind, register_world, unregister_world


# ---------------------------------------------------------------- a tool: one decorated method
class HornTools(ControllerTools):
    @tool("sound_horn")
    def sound_horn(self, times: Annotated[int, Field(ge=1, le=3, description="how many short blasts")], *,
                   apply_at_s: float | None = None) -> dict[str, Any]:
        """Sound the horn a few times (the specification is unchanged)."""
        return self._apply("sound_horn", {"times": times}, lambda specification: specification, apply_at_s)


@pytest.fixture
def horn_tools():
    yield
    TABLE[:] = [row for row in TABLE if row.name != "sound_horn"]


def test_a_toy_tool_is_listed_with_its_schema_and_called_over_mcp(horn_tools):
    world = PlainWorld(PlainConfig())
    lanes = world.lanes()
    slot = SpecificationSlot(Specification.of(PathTracking(path=lanes.lanes["center"], lane="center", v_ref_mps=10.0)))
    server = build_server(HornTools(slot, world.lanes), lambda: world.observation.to_json())

    async def go():
        async with Client(server.mcp_server, cache=None) as client:
            listed = {t.name: t for t in (await client.list_tools()).tools}
            result = await client.call_tool("sound_horn", {"times": 2})
            try:  # refused by its schema: a protocol error or an error result, either way nothing ran
                refused = (await client.call_tool("sound_horn", {"times": 7})).is_error
            except MCPError:
                refused = True
            return listed, result, refused

    listed, result, refused = asyncio.run(asyncio.wait_for(go(), 60))
    assert refused
    horn = listed["sound_horn"]
    assert horn.description == "Sound the horn a few times (the specification is unchanged)."
    assert horn.input_schema["properties"]["times"]["maximum"] == 3 and horn.input_schema["required"] == ["times"]
    assert result.structured_content["arguments"] == {"times": 2} and not result.structured_content["changed"]
    assert ToolName.SET_REFERENCE_SPEED in listed  # the table's other tools stay
    plain = build_server(ControllerTools(slot, world.lanes), lambda: world.observation.to_json())

    async def plain_names():
        async with Client(plain.mcp_server, cache=None) as client:
            return {t.name for t in (await client.list_tools()).tools}

    assert "sound_horn" not in asyncio.run(asyncio.wait_for(plain_names(), 60))  # the subclass's tool only
    world.close()


# ---------------------------------------------------------------- a world: its config, how to start it, one line
class RingRoadConfig(FrozenConfig):
    """A toy world: the plain world's straight road, only shorter and slower."""

    length_m: float = Field(400.0, gt=0)
    speed_limit_mps: float = Field(12.0, gt=0)

    def plain(self) -> PlainConfig:
        return PlainConfig(road=PlainRoad(length_m=self.length_m, speed_limit_mps=self.speed_limit_mps))


def start_ring_road(config: RingRoadConfig, seed: int) -> PlainWorld:
    return PlainWorld(config.plain(), seed=seed)


def ring_road_drawing(config_json: dict) -> Any:
    from agentic_mpc.plots.road import plain_road

    return plain_road(RingRoadConfig.model_validate(config_json).plain().model_dump(mode="json"))


@pytest.fixture
def ring_road():
    register_world(WorldKind("ring_road", "toy ring road", RingRoadConfig, start_ring_road, ring_road_drawing))
    yield
    unregister_world("ring_road")


def test_a_toy_world_runs_a_scenario_and_its_road_is_drawn(ring_road, tmp_path):
    file = tmp_path / "ring.yaml"
    file.write_text("name: ring\nring_road: {length_m: 300}\nspecification:\n"
                    "  path_tracking: {lane: center, v_ref_mps: 8.0}\nduration_s: 2.0\n"
                    "outputs: {plot: false, replay: false}\n")
    scenario = load_scenario(file).base
    assert scenario.world_kind == "ring_road" and scenario.world.length_m == 300.0
    summary = run_scenario(scenario, tmp_path / "run")
    assert summary["steps"] == 50 and summary["collisions"] == 0
    saved = json.loads((tmp_path / "run" / "scenario.json").read_text())
    assert saved["ring_road"] == {"length_m": 300.0, "speed_limit_mps": 12.0}
    from agentic_mpc.plots.road import run_road

    assert sorted(run_road(saved).lanes().lanes) == ["center", "left", "right"]
    bad = tmp_path / "bad.yaml"
    bad.write_text(file.read_text().replace("length_m: 300", "length_m: -3"))
    with pytest.raises(ValueError, match=r"bad.yaml:2: ring_road.length_m: Input should be greater than 0"):
        load_scenario(bad)


# ---------------------------------------------------------------- a backend: its settings class, one line
class SlowDownBackend:
    """Answers every message by halving the speed limit's worth of v_ref: one call, then a reply."""

    name = "slow_down"
    reads_situation = False

    async def complete(self, history, tools) -> BackendReply:
        if history[-1].role == "tool":
            return BackendReply("Slowed down.")
        return BackendReply("", (ToolCall(id="slow-1", name=ToolName.SET_REFERENCE_SPEED, arguments={"v_ref": 5.0}),))

    async def aclose(self) -> None:
        return None


class SlowDownSettings(AgentRunSettings):
    backend: Literal["slow_down"] = "slow_down"

    def build_backend(self, lefthand: bool) -> SlowDownBackend:
        return SlowDownBackend()


@pytest.fixture
def slow_down():
    register_backend(SlowDownSettings)
    yield
    unregister_backend("slow_down")


def test_a_toy_backend_answers_ask_and_a_scenario_can_name_it(slow_down, capsys):
    assert cli.main(["ask", "whatever you say", "--backend", "slow_down", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == [{"tool": "set_reference_speed", "arguments": {"v_ref": 5.0}}]
    from agentic_mpc.agent.settings import agent_settings

    assert isinstance(agent_settings({"backend": "slow_down", "latency_s": 0.2}), SlowDownSettings)
