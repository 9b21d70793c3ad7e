"""Shared set-up for the agent tests: a run loop over the plain-Python world, its MCP server, an agent over it."""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

from collections.abc import Iterator

import pytest

from agentic_mpc.mcp.server import AgenticMPCServer
from agentic_mpc.primitives import ObstacleAvoidance, PathTracking, Specification
from agentic_mpc.run.loop import LoopSettings, RunLoop
from agentic_mpc.world.plain import PlainWorld
from agentic_mpc.world.plain_config import PlainConfig, PlainObstacle, ScriptedVehicle


def paper_specification(world: PlainWorld) -> Specification:
    """The paper's initial specification: J1 on the center lane at 15 m/s, J2 around the world's obstacles."""
    lanes = world.lanes().lanes
    return Specification.of(
        PathTracking(path=lanes["center"], lane="center", v_ref_mps=15.0),
        ObstacleAvoidance(obstacles=world.obstacle_circles()),
    )


def plain_loop(config: PlainConfig, *, seed: int = 0, duration_s: float = 3600.0, pace: float | None = None,
               **loop_options) -> RunLoop:
    """A run loop (no goal stop) over a plain world from the paper's initial specification."""
    world = PlainWorld(config, seed=seed)
    settings = LoopSettings(duration_s=duration_s, stop_at_goal=False, pace=pace)
    return RunLoop(world, paper_specification(world), settings, seed=seed, **loop_options)


def paper_start_config() -> PlainConfig:
    """The paper's start: center lane at 15 m/s with obstacle avoidance, no traffic."""
    return PlainConfig(obstacles=(PlainObstacle(id="obstacle0", x_m=400.0, y_m=0.0, radius_m=2.0),))


@pytest.fixture
def loop() -> Iterator[RunLoop]:
    with plain_loop(paper_start_config()) as built:
        yield built


@pytest.fixture
def server(loop: RunLoop) -> AgenticMPCServer:
    return loop.server


def ambulance_config() -> PlainConfig:
    """Scenario 2 in the plain world: an ambulance appears 100 m behind the ego in the centre lane."""
    return PlainConfig(
        vehicles=(
            ScriptedVehicle(id="ambulance0", lane="center", x_m=None, desired_speed_mps=24.0, type_id="ambulance",
                            emergency=True, appear_at_s=0.5, behind_ego_m=100.0),
        ),
        obstacles=(PlainObstacle(id="obstacle0", x_m=2000.0, y_m=0.0, radius_m=2.0),),
    )


def ambulance_loop(seed: int = 0, **loop_options) -> RunLoop:
    return plain_loop(ambulance_config(), seed=seed, **loop_options)
