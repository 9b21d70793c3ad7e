"""The world interface: what the run loop needs from whatever simulates the road around the ego.

A world owns the ego's plant (the paper's vehicle model) and everything around it. It does not build the
controller, the specification or the tools: the run loop (:mod:`agentic_mpc.run.loop`) does, and steps any
world through this interface. Implementations: :class:`agentic_mpc.sumo.world.SumoWorld` (SUMO traffic via
libsumo) and :class:`agentic_mpc.world.plain.PlainWorld` (plain Python, no traffic simulator).

One control step of the loop at time t::

    surroundings = world.surroundings(horizon, tracked_path, side)  # what J0 must keep clear of
    inputs = controller.step(world.ego_state, specification, surroundings)
    world.advance(inputs.delta, inputs.throttle, inputs.brake)    # the plant moves, the world reacts: t + dt
    world.observation                                             # what is seen at t + dt
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import Circle, Surroundings
from agentic_mpc.world.lanes import RoadLanes
from agentic_mpc.world.observation import Observation


class WorldError(RuntimeError):
    """A world that cannot start, or that failed during a run (it is closed; what was recorded is kept)."""


class WorldReadings:
    """The two readings every world keeps between steps and the :class:`World` protocol asks for: the latest
    observation and the ego's state (a world sets ``_observation`` and ``_state``)."""

    _observation: Observation | None
    _state: np.ndarray

    @property
    def observation(self) -> Observation:
        if self._observation is None:
            raise WorldError("the world has made no observation yet")
        return self._observation

    @property
    def ego_state(self) -> np.ndarray:
        return self._state


@runtime_checkable
class World(Protocol):
    """What the run loop steps. Times are simulation seconds; lengths metres; angles radians from +x."""

    dt_s: float
    """The control step (the vehicle model's sample time)."""
    goal_s_m: float
    """Along-road position of the ego that ends a run that stops at its goal."""

    @property
    def observation(self) -> Observation:
        """What is seen now (after the last :meth:`advance`)."""

    @property
    def ego_state(self) -> np.ndarray:
        """The plant's state now: [x_m, y_m, phi_rad, v_mps] of the ego's centre."""

    @property
    def time_s(self) -> float: ...

    def lanes(self) -> RoadLanes:
        """The ego road's lanes by role, its speed limit and handedness."""

    def lane(self, ref: int | str) -> tuple[str, LanePath]:
        """A lane of the ego's road by index or role: (its role, its centre line). Raises WorldError."""

    def lane_index_of(self, path: LanePath | None) -> int | None:
        """Which lane of the ego's road ``path`` is (the lane J1 tracks), or None."""

    def lateral_offset_m(self, lane_index: int, x_m: float, y_m: float) -> float:
        """Signed distance of a point from a lane's centre line (positive to the left)."""

    def obstacle_circles(self, only_in_j2: bool = False) -> tuple[Circle, ...]:
        """J2's discs around the world's static obstacles (only those marked for J2 if asked)."""

    def surroundings(self, horizon: int, tracked_path: LanePath | None, plan: Any = None) -> Surroundings:
        """The controller's surroundings over ``horizon`` steps from now; ``plan``: this step's
        :class:`~agentic_mpc.tactics.layer.TacticalPlan` (None: no tactics), which a world that offers a
        ``tactical_road`` (the road the tactics layer sees) applies: the lane J1 follows, the queue room, the
        passing lanes, gap acceptance. A world without ``tactical_road`` drives without tactics."""

    def advance(self, delta: float, throttle: float, brake: float) -> Observation:
        """Apply the ego's inputs for one control step; returns the new observation. Raises WorldError."""

    def signal_intention(self, planned_xy: np.ndarray) -> None:
        """The controller's plan, the ego's centre over the horizon ((H, 2), m): where the world's other drivers
        can react to what the ego is about to do (SUMO: followers in a lane it enters open a gap), they are told."""

    def time_loss_s(self, vehicle_id: str) -> float | None:
        """How much time a vehicle has lost against driving at its desired speed (None if unknown)."""

    def close(self) -> None:
        """Release the simulator (idempotent); the last observation stays readable."""
