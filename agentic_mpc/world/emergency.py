"""The one emergency-vehicle event detector: an emergency vehicle approaching from behind, and its passing.

Read by the scenario's message timeline (messages due "a delay after an event") and by the agent's
observation messages (the world wakes the agent). Both see the same events at the same step.

- approaching: an emergency vehicle on the ego's road is behind the ego within ``alert_distance_m``
  (bumper to bumper);
- passed: every vehicle announced as approaching is ahead of the ego by at least ``passed_margin_m``
  (its rear to the ego's front), or has left the world.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from agentic_mpc.world.observation import EmergencyVehicleObservation, Observation

EventKind = Literal["emergency_vehicle_approaching", "emergency_vehicle_passed"]
EVENT_KINDS: tuple[EventKind, ...] = ("emergency_vehicle_approaching", "emergency_vehicle_passed")

PASSED_MARGIN_M = 10.0
"""An emergency vehicle has passed once its rear is this far ahead of the ego's front."""


@dataclass(frozen=True)
class EmergencyEvent:
    kind: EventKind
    time_s: float
    vehicles: tuple[str, ...]
    """How the vehicles are named in messages: "ambulance 'ambulance0'"."""
    distance_m: float | None
    """approaching: how far behind; passed: how far ahead the nearest now is (None: out of the world)."""

    def message(self) -> str:
        """The observation message that wakes the agent."""
        stamp = f"Observation (t = {self.time_s:.1f} s): "
        names = ", ".join(self.vehicles)
        if self.kind == "emergency_vehicle_approaching":
            return f"{stamp}An emergency vehicle ({names}) is approaching from behind, {self.distance_m:.0f} m back."
        where = f"; it is now {self.distance_m:.0f} m ahead" if self.distance_m is not None else "; it is out of sight"
        return f"{stamp}The emergency vehicle ({names}) has passed us{where}."


def _label(emergency: EmergencyVehicleObservation) -> str:
    vehicle = emergency.vehicle
    kind = vehicle.type_id or vehicle.vclass
    return f"{kind} '{vehicle.id}'" if kind else f"'{vehicle.id}'"


@dataclass
class EmergencyDetector:
    """Feed it every observation (:meth:`update`); it returns the events that observation brings."""

    alert_distance_m: float = 80.0
    passed_margin_m: float = PASSED_MARGIN_M
    first_times_s: dict[str, float] = field(default_factory=dict)
    """When each kind of event happened first (what the message timeline waits for)."""
    _announced: dict[str, str] = field(default_factory=dict)

    def update(self, observation: Observation) -> list[EmergencyEvent]:
        t = observation.time_s
        present = {e.vehicle.id: e for e in observation.emergency_vehicles}
        events = []
        new = [
            e for e in observation.emergency_vehicles
            if e.vehicle.id not in self._announced and e.relation == "behind" and e.vehicle.relative_lane is not None
            and e.distance_m <= self.alert_distance_m
        ]
        for emergency in new:
            self._announced[emergency.vehicle.id] = _label(emergency)
            events.append(EmergencyEvent("emergency_vehicle_approaching", t, (_label(emergency),), emergency.distance_m))
        if self._announced and not new:
            waiting = [
                vehicle_id for vehicle_id in self._announced
                if vehicle_id in present
                and not (present[vehicle_id].relation == "ahead" and present[vehicle_id].distance_m >= self.passed_margin_m)
            ]
            if not waiting:
                ahead = [present[v].distance_m for v in self._announced if v in present]
                events.append(EmergencyEvent("emergency_vehicle_passed", t, tuple(self._announced.values()),
                                             min(ahead) if ahead else None))
                self._announced.clear()
        for event in events:
            self.first_times_s.setdefault(event.kind, event.time_s)
        return events
