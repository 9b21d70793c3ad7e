"""The passenger's message timeline: each message once, when due (at a simulation time, or a delay after an
emergency-vehicle event that the world's observations showed)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from agentic_mpc.world.emergency import EmergencyDetector


class TimedMessage(Protocol):
    """A message and its trigger (``agentic_mpc.scenario.schema.Message`` is one)."""

    text: str
    at_s: float | None
    event: str | None
    delay_s: float


@dataclass
class MessageSchedule:
    """Hands out each message once, when due; event times come from ``detector``."""

    messages: tuple[TimedMessage, ...]
    detector: EmergencyDetector
    _sent: set[int] = field(default_factory=set)

    def due(self, time_s: float) -> list[TimedMessage]:
        ready = []
        for index, message in enumerate(self.messages):
            if index in self._sent:
                continue
            if message.at_s is not None:
                at = message.at_s
            else:
                event_time = self.detector.first_times_s.get(message.event or "")
                if event_time is None:
                    continue
                at = event_time + message.delay_s
            if time_s + 1e-9 >= at:
                self._sent.add(index)
                ready.append(message)
        return ready

    @property
    def pending(self) -> list[TimedMessage]:
        return [m for i, m in enumerate(self.messages) if i not in self._sent]
