"""A closed loop without a simulator: the controller drives the paper's vehicle model directly.

Used for the paper's scenarios without traffic, for tests of the controller, and as the plant of the
SUMO co-simulation's ego (which adds the world around it). Specification changes are scheduled by step
and applied through the :class:`SpecificationSlot`, between control steps, as the agent's would be.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from agentic_mpc.controller import FourierMPPI
from agentic_mpc.primitives import Specification, SpecificationSlot
from agentic_mpc.vehicle import step as vehicle_step

SpecificationChange = Callable[[Specification], Specification]


@dataclass
class Trajectory:
    """What a closed-loop run recorded, one row per control step."""

    dt_s: float
    states: list[np.ndarray] = field(default_factory=list)
    """State before each step, then the final state: len = steps + 1."""
    inputs: list[np.ndarray] = field(default_factory=list)
    costs: list[float] = field(default_factory=list)
    solve_ms: list[float] = field(default_factory=list)
    specifications: list[str] = field(default_factory=list)

    @property
    def state_array(self) -> np.ndarray:
        return np.array(self.states)

    @property
    def input_array(self) -> np.ndarray:
        return np.array(self.inputs)

    @property
    def time_s(self) -> np.ndarray:
        return np.arange(len(self.states)) * self.dt_s


def run_closed_loop(
    controller: FourierMPPI,
    slot: SpecificationSlot,
    initial_state: np.ndarray,
    steps: int,
    changes: Mapping[int, SpecificationChange] | None = None,
) -> Trajectory:
    """Drive ``steps`` control steps; ``changes[k]`` is applied to the slot just before step k."""
    changes = changes or {}
    trajectory = Trajectory(controller.params.dt_s)
    state = np.asarray(initial_state, dtype=np.float64).copy()
    for k in range(steps):
        if k in changes:
            slot.update(changes[k])
        specification = slot.current  # one snapshot per step
        output = controller.step(state, specification)
        trajectory.states.append(state)
        trajectory.inputs.append(output.inputs)
        trajectory.costs.append(output.cost_min)
        trajectory.solve_ms.append(output.solve_ms)
        trajectory.specifications.append(specification.summary())
        state = vehicle_step(state, output.delta, output.throttle, output.brake, controller.params)
    trajectory.states.append(state)
    return trajectory
