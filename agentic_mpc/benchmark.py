"""Timing of the controller step, shared by ``agentic-mpc bench`` and ``benchmarks/``."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.obstacle_demo import ObstacleScene
from agentic_mpc.primitives import PreferredSteeringDirection


def benchmark_controller_step(horizon: int, samples: int, steps: int, backend: str = "fast", seed: int = 0) -> dict[str, Any]:
    """Median/p10/p90 of ``FourierMPPI.step`` on the paper's Scenario 1 specification (J0 + J1 + J2 + J3).

    Each step prepares the specification (reference points), samples, rolls out, scores and weights:
    everything a control step costs except the plant.
    """
    if steps < 1:
        raise ValueError(f"--steps must be at least 1, got {steps}")
    scene = ObstacleScene()
    specification = scene.initial_specification().attach(PreferredSteeringDirection(direction="left"))
    config = MPPIConfig(horizon=horizon, samples=samples, backend=backend)  # type: ignore[arg-type]
    controller = FourierMPPI(config, seed=seed)
    state = scene.initial_state()
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
