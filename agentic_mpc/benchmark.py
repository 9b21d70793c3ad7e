"""Timing of the controller step, shared by ``agentic-mpc bench`` and ``benchmarks/``."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import (
    Circle,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
)


def scenario1_specification() -> Specification:
    """The paper's Scenario 1 with J3 attached: J1 on a straight lane at 15 m/s, J2 around a 2 m circle 45 m
    ahead, J3 preferring the left."""
    lane = LanePath.straight((-20.0, 0.0), (400.0, 0.0), name="center")
    return Specification.of(
        PathTracking(path=lane, lane="center", v_ref_mps=15.0),
        ObstacleAvoidance(obstacles=(Circle(x_m=45.0, y_m=0.0, radius_m=2.0, label="obstacle"),)),
        PreferredSteeringDirection(direction="left"),
    )


def benchmark_controller_step(horizon: int, samples: int, steps: int, backend: str = "fast", seed: int = 0) -> dict[str, Any]:
    """Median/p10/p90 of ``FourierMPPI.step`` on the paper's Scenario 1 specification (J0 + J1 + J2 + J3).

    Each step prepares the specification (reference points), samples, rolls out, scores and weights:
    everything a control step costs except the plant.
    """
    if steps < 1:
        raise ValueError(f"--steps must be at least 1, got {steps}")
    specification = scenario1_specification()
    config = MPPIConfig(horizon=horizon, samples=samples, backend=backend)  # type: ignore[arg-type]
    controller = FourierMPPI(config, seed=seed)
    state = np.array([0.0, 0.0, 0.0, 15.0])
    started = time.perf_counter()
    controller.step(state, specification)  # compiles the kernel, or loads it from numba's cache
    first_step_s = time.perf_counter() - started
    durations = np.empty(steps)
    for k in range(steps):
        started = time.perf_counter()
        controller.step(state, specification)
        durations[k] = time.perf_counter() - started
    durations_ms = durations * 1e3
    median = float(np.median(durations_ms))
    return {
        "horizon": horizon,
        "samples": samples,
        "steps": steps,
        "backend": backend,
        "median_ms": round(median, 4),
        "p10_ms": round(float(np.percentile(durations_ms, 10)), 4),
        "p90_ms": round(float(np.percentile(durations_ms, 90)), 4),
        "p99_ms": round(float(np.percentile(durations_ms, 99)), 4),
        "realtime_factor": round(controller.params.dt_s * 1e3 / median, 1),
        "first_step_s": round(first_step_s, 4),
    }
