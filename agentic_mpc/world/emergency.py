"""The one emergency-vehicle event detector: an emergency vehicle approaching from behind, and its passing.

Read by the scenario's message timeline (messages due "a delay after an event", on the world's
:class:`Observation`) and by the agent's emergency watch (on what it read from the MCP resource
``sumo://emergency-vehicles``, :meth:`EmergencyDetector.update_json`). Both see the same events at the same step.

- approaching: an emergency vehicle on the ego's road is behind the ego within ``alert_distance_m``
  (bumper to bumper);
- passed: every vehicle announced as approaching is ahead of the ego by at least ``passed_margin_m``
  (its rear to the ego's front), or has left the world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

from agentic_mpc.world import ALERT_DISTANCE_M
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


@dataclass(frozen=True, slots=True)
class Sighting:
    """What the detector needs of one emergency vehicle, from an observation or its JSON."""

    id: str
    label: str
    relation: str
    on_road: bool
    """On a lane of the ego's road (its ``relative_lane`` is known)."""
    distance_m: float

    @classmethod
    def of(cls, emergency: EmergencyVehicleObservation) -> Sighting:
        vehicle = emergency.vehicle
        return cls(vehicle.id, _label(vehicle.id, vehicle.type_id or vehicle.vclass), emergency.relation,
                   vehicle.relative_lane is not None, emergency.distance_m)

    @classmethod
    def of_json(cls, item: dict[str, Any]) -> Sighting:
        """From one entry of the resource's ``emergency_vehicles`` (``EmergencyVehicleObservation.to_json``)."""
        distance = item.get("distance_m")
        return cls(str(item["id"]), _label(str(item["id"]), item.get("type_id") or item.get("vclass") or ""),
                   str(item.get("relation", "")), item.get("relative_lane") is not None,
                   float(distance) if isinstance(distance, int | float) else math.inf)


def _label(vehicle_id: str, kind: str) -> str:
    return f"{kind} '{vehicle_id}'" if kind else f"'{vehicle_id}'"


@dataclass
class EmergencyDetector:
    """Feed it every observation (:meth:`update`); it returns the events that observation brings."""

    alert_distance_m: float = ALERT_DISTANCE_M
    passed_margin_m: float = PASSED_MARGIN_M
    first_times_s: dict[str, float] = field(default_factory=dict)
    """When each kind of event happened first (what the message timeline waits for)."""
    _announced: dict[str, str] = field(default_factory=dict)

    def update(self, observation: Observation) -> list[EmergencyEvent]:
        return self.update_sightings(observation.time_s, [Sighting.of(e) for e in observation.emergency_vehicles])

    def update_json(self, resource: dict[str, Any]) -> list[EmergencyEvent]:
        """The same on the JSON of the MCP resource ``sumo://emergency-vehicles`` (``time_s``,
        ``emergency_vehicles``); raises ``ValueError`` for a resource without them."""
        t, items = resource.get("time_s"), resource.get("emergency_vehicles")
        if not isinstance(t, int | float) or not isinstance(items, list):
            raise ValueError("not an emergency-vehicles resource: time_s or emergency_vehicles missing")
        return self.update_sightings(float(t), [Sighting.of_json(item) for item in items if isinstance(item, dict)])

    def update_sightings(self, t: float, sightings: list[Sighting]) -> list[EmergencyEvent]:
        present = {e.id: e for e in sightings}
        events = []
        new = [
            e for e in sightings
            if e.id not in self._announced and e.relation == "behind" and e.on_road and e.distance_m <= self.alert_distance_m
        ]
        for emergency in new:
            self._announced[emergency.id] = emergency.label
            events.append(EmergencyEvent("emergency_vehicle_approaching", t, (emergency.label,), emergency.distance_m))
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
