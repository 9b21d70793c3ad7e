"""The driving state the offline rules backend works from: the initial and current specification."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from agentic_mpc.agent.messages import Message


@dataclass(frozen=True, slots=True)
class DrivingState:
    """What the rules need to know about the specification: lane, speed, steering preference."""

    lane: str | None
    v_ref_mps: float | None
    steering: str | None

    @classmethod
    def from_attached(cls, attached: Sequence[dict[str, Any]]) -> DrivingState:
        lane = v_ref = steering = None
        for primitive in attached:
            if primitive.get("kind") == "path_tracking":
                lane, v_ref = primitive.get("lane"), primitive.get("v_ref_mps")
            elif primitive.get("kind") == "preferred_steering_direction":
                steering = primitive.get("direction")
        return cls(lane, None if v_ref is None else float(v_ref), steering)

    def describe(self) -> str:
        parts = []
        if self.lane is not None:
            parts.append(f"following the {self.lane} lane at {self.v_ref_mps:g} m/s ({self.v_ref_mps * 3.6:.0f} km/h)")
        parts.append(f"evading obstacles to the {self.steering}" if self.steering else "no preferred evasion side")
        return "; ".join(parts)


def driving_states(history: Sequence[Message]) -> tuple[DrivingState, DrivingState]:
    """(initial, current) driving state, from the system message and the latest successful tool result."""
    initial_attached: list[dict[str, Any]] = []
    for message in history:
        if message.role == "system" and message.data:
            initial_attached = message.data.get("initial_specification", {}).get("attached", [])
    current_attached = initial_attached
    for message in history:
        if message.role == "tool" and not message.is_error and message.data and "attached" in message.data:
            current_attached = message.data["attached"]
    return DrivingState.from_attached(initial_attached), DrivingState.from_attached(current_attached)
