"""Shared set-up for the agent tests: the plain-Python world, its MCP server, an agent over it."""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import pytest

from agentic_mpc.mcp_server import AgenticMPCServer, build_server
from agentic_mpc.plain_world import PlainWorld, PlainWorldConfig, ScriptedVehicle, demo_config
from agentic_mpc.primitives import Circle


@pytest.fixture
def world() -> PlainWorld:
    """The paper's start: center lane at 15 m/s with obstacle avoidance, no traffic."""
    return PlainWorld(PlainWorldConfig(obstacles=[Circle(x_m=400.0, y_m=0.0, radius_m=2.0)]))


@pytest.fixture
def server(world: PlainWorld) -> AgenticMPCServer:
    built = build_server(world.tools, world.latest_observation)
    world.on_step.append(built.publish_observation)
    return built


def ambulance_world(seed: int = 0) -> PlainWorld:
    """Scenario 2 in the plain world: an ambulance appears 100 m behind the ego in the centre lane."""
    config = demo_config(ambulance_at_s=None)
    config.vehicles = [
        ScriptedVehicle("ambulance0", "center", None, 24.0, type="ambulance", emergency=True, appear_at_s=0.5,
                        behind_ego_m=100.0)
    ]
    config.obstacles = [Circle(x_m=2000.0, y_m=0.0, radius_m=2.0)]
    config.seed = seed
    return PlainWorld(config)
