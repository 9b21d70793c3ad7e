"""The one emergency-vehicle event detector of a run: an emergency vehicle approaching from behind, and its
passing.

The run loop feeds it every observation; what it decides is read by the scenario's message timeline
(messages due "a delay after an event", :attr:`EmergencyDetector.first_times_s`) and by the agent: its
observation messages are these events, listed in the MCP resource ``sumo://emergency-vehicles``
(:attr:`EmergencyDetector.events`, :meth:`EmergencyEvent.to_json`). Both see the same events at the same step.

- approaching: an emergency vehicle on the ego's road is behind the ego within ``alert_distance_m``
  (bumper to bumper);
- passed: every vehicle announced as approaching is ahead of the ego by at least ``passed_margin_m``
  (its rear to the ego's front), or has left the world.
"""

from __future__ import annotations

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

    def to_json(self) -> dict[str, Any]:
        """As the resource lists it (rounded as the observations' JSON is)."""
        distance = None if self.distance_m is None else round(self.distance_m, 3)
        return {"kind": self.kind, "time_s": round(self.time_s, 3), "vehicles": list(self.vehicles),
                "distance_m": distance}

    @classmethod
    def from_json(cls, item: Any) -> EmergencyEvent:
        """Back from :meth:`to_json`; ``ValueError`` for anything else."""
        fields = item if isinstance(item, dict) else {}
        kind, t, vehicles, distance = (fields.get(key) for key in ("kind", "time_s", "vehicles", "distance_m"))
        if (kind not in EVENT_KINDS or not isinstance(t, int | float) or not isinstance(vehicles, list)
                or not (distance is None or isinstance(distance, int | float))):
            raise ValueError(f"not an emergency-vehicle event: {item!r}")
        return cls(kind, float(t), tuple(str(v) for v in vehicles), None if distance is None else float(distance))


@dataclass(frozen=True, slots=True)
class Sighting:
    """What the detector needs of one emergency vehicle."""

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


def _label(vehicle_id: str, kind: str) -> str:
    return f"{kind} '{vehicle_id}'" if kind else f"'{vehicle_id}'"


@dataclass
class EmergencyDetector:
    """Feed it every observation (:meth:`update`); it returns the events that observation brings."""

    alert_distance_m: float = ALERT_DISTANCE_M
    passed_margin_m: float = PASSED_MARGIN_M
    first_times_s: dict[str, float] = field(default_factory=dict)
    """When each kind of event happened first (what the message timeline waits for)."""
    events: list[EmergencyEvent] = field(default_factory=list)
    """Every event so far, in order (what the agent reads: a late reader misses none)."""
    _announced: dict[str, str] = field(default_factory=dict)

    def update(self, observation: Observation) -> list[EmergencyEvent]:
        return self.update_sightings(observation.time_s, [Sighting.of(e) for e in observation.emergency_vehicles])

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
        self.events.extend(events)
        return events
