"""Shared fixtures of the SUMO tests: they run real SUMO (libsumo), one simulation at a time."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import pytest

from agentic_mpc.primitives import ObstacleAvoidance, PathTracking, Specification
from agentic_mpc.run.loop import LoopSettings, RunLoop
from agentic_mpc.run.recorder import StepOutcome
from agentic_mpc.sumo import bridge
from agentic_mpc.sumo.config import SumoConfig
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.world.observation import CollisionObservation


@pytest.fixture(autouse=True)
def _no_simulation_left_open():
    """libsumo runs one simulation per process: a test that leaves one open would break the next ones."""
    yield
    leftover = bridge._active
    if leftover is not None:
        leftover.close()
        pytest.fail("a test left a SUMO simulation open")


@pytest.fixture
def report(request):
    """Measured numbers for the test output even without ``-s``: kept with the test's report and printed in the
    summary's "measured" section (tests/conftest.py), also when the tests run in several processes."""

    def emit(*lines: str) -> None:
        request.node.user_properties.extend(("measured", line) for line in lines)

    return emit


# --- running a SUMO world under the run loop -------------------------------------------------------------
def default_specification(world: SumoWorld, v_ref_mps: float = 15.0) -> Specification:
    """J1 on the ego's start lane at ``v_ref_mps``, plus J2 over the obstacles marked ``in_j2`` (if any)."""
    role, path = world.lane(world.config.ego.lane)
    primitives: list[Any] = [PathTracking(path=path, lane=role, v_ref_mps=v_ref_mps)]
    circles = world.obstacle_circles(only_in_j2=True)
    if circles:
        primitives.append(ObstacleAvoidance(obstacles=circles))
    return Specification.of(*primitives)


def sumo_loop(config: SumoConfig, seed: int = 0, v_ref_mps: float = 15.0, stop_at_goal: bool = True) -> RunLoop:
    """A world of ``config`` and a run loop over it from :func:`default_specification`, both with ``seed``
    (SUMO's and the controller's). The loop has no end time of its own: :func:`drive` gives it one."""
    world = SumoWorld(config, seed=seed)
    try:
        return RunLoop(world, default_specification(world, v_ref_mps),
                       LoopSettings(duration_s=math.inf, stop_at_goal=stop_at_goal), seed=seed)
    except BaseException:
        world.close()
        raise


def drive(
    loop: RunLoop,
    duration_s: float,
    on_step: Callable[[RunLoop, StepOutcome], bool | None] | None = None,
) -> list[CollisionObservation]:
    """Step ``loop`` for ``duration_s`` more seconds of simulated time, or until it is finished (the goal, if
    it stops there), as :meth:`RunLoop.run` does; ``on_step(loop, outcome)`` runs after every step (scenario
    scripts change the specification from there, as the agent would) and returning True ends the drive.

    Returns every collision SUMO or the geometry check reported in the observations seen (the one at the
    start included), whoever was involved."""
    world = loop.world
    loop.settings = dataclasses.replace(loop.settings, duration_s=world.time_s + duration_s)
    loop.stop.clear()
    collisions = list(world.observation.collisions)
    while not loop.finished:
        outcome = loop.step()
        collisions.extend(world.observation.collisions)
        if on_step is not None and on_step(loop, outcome):
            break
    return collisions


def position_error_m(row: dict[str, Any]) -> float:
    """How far SUMO's ego (``sumo_x_m``, ``sumo_y_m``) was from our model's at a recorded step."""
    return math.hypot(row["x_m"] - row["sumo_x_m"], row["y_m"] - row["sumo_y_m"])
