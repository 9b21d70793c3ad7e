"""When the scenario's user messages are due: at a simulation time, or a delay after an event SUMO shows."""

from __future__ import annotations

from dataclasses import dataclass, field

from agentic_mpc.scenario.schema import Message
from agentic_mpc.sumo.observations import Observation

PASSED_MARGIN_M = 10.0
"""An emergency vehicle has passed once its rear is this far ahead of the ego's front."""


@dataclass
class EmergencyEvents:
    """Detects ``emergency_vehicle_approaching`` and ``emergency_vehicle_passed`` from observations."""

    alert_distance_m: float
    times_s: dict[str, float] = field(default_factory=dict)
    _approaching: set[str] = field(default_factory=set)

    def update(self, observation: Observation) -> None:
        t = observation.time_s
        present = set()
        for emergency in observation.emergency_vehicles:
            vehicle_id = emergency.vehicle.id
            present.add(vehicle_id)
            if emergency.relation == "behind" and emergency.distance_m <= self.alert_distance_m:
                self._approaching.add(vehicle_id)
                self.times_s.setdefault("emergency_vehicle_approaching", t)
            if vehicle_id in self._approaching and emergency.relation == "ahead" and emergency.distance_m >= PASSED_MARGIN_M:
                self.times_s.setdefault("emergency_vehicle_passed", t)
        if self._approaching - present and "emergency_vehicle_approaching" in self.times_s:
            self.times_s.setdefault("emergency_vehicle_passed", t)  # it left the simulation


@dataclass
class MessageSchedule:
    """Hands out each message once, when due."""

    messages: tuple[Message, ...]
    events: EmergencyEvents
    _sent: set[int] = field(default_factory=set)

    def due(self, time_s: float) -> list[Message]:
        ready = []
        for index, message in enumerate(self.messages):
            if index in self._sent:
                continue
            if message.at_s is not None:
                at = message.at_s
            else:
                event_time = self.events.times_s.get(message.event or "")
                if event_time is None:
                    continue
                at = event_time + message.delay_s
            if time_s + 1e-9 >= at:
                self._sent.add(index)
                ready.append(message)
        return ready

    @property
    def pending(self) -> list[Message]:
        return [m for i, m in enumerate(self.messages) if i not in self._sent]
