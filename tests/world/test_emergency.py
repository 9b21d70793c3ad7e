"""The emergency-vehicle event detector on typed observations: approaching from behind, then passed."""

from __future__ import annotations

import pytest

from agentic_mpc.vehicle import throttle_for_steady_speed
from agentic_mpc.world.emergency import EmergencyDetector, EmergencyEvent
from agentic_mpc.world.observation import (
    EgoObservation,
    EmergencyVehicleObservation,
    Observation,
    VehicleObservation,
)
from agentic_mpc.world.plain import PlainWorld
from agentic_mpc.world.plain_config import PlainConfig, ScriptedVehicle

EGO = EgoObservation("ego", 0.0, 0.0, 3.0, 15.0, "lane0", 1, "center", "road", 0.0, 0.0, 4.5, 1.8)


def emergency(vehicle_id: str, relation: str, distance_m: float, relative_lane: int | None = 0,
              type_id: str = "ambulance") -> EmergencyVehicleObservation:
    offset = distance_m + 4.5 if relation == "ahead" else -(distance_m + 4.5)
    vehicle = VehicleObservation(
        vehicle_id, type_id, "emergency", offset, 0.0, 3.0, 20.0, 20.0, 0.0, "lane0", 1, "center", "road", 4.5, 1.8,
        offset, offset, distance_m, relation, relative_lane, offset, 0.0, "", 0.0,
    )
    return EmergencyVehicleObservation(vehicle, relation, distance_m, 5.0, distance_m / 5.0, relative_lane == 0)


def observation(time_s: float, *emergency_vehicles: EmergencyVehicleObservation) -> Observation:
    return Observation(time_s, EGO, tuple(e.vehicle for e in emergency_vehicles), tuple(emergency_vehicles), (), ())


def test_approaching_behind_within_the_alert_distance_then_passed_ahead():
    detector = EmergencyDetector()  # alert 80 m, passed 10 m ahead
    far = emergency("amb", "behind", 120.0)
    assert detector.update(observation(1.0, far)) == []
    near = emergency("amb", "behind", 60.0)
    (event,) = detector.update(observation(2.0, near))
    assert event.kind == "emergency_vehicle_approaching" and event.vehicles == ("ambulance 'amb'",)
    assert "approaching from behind, 60 m back" in event.message() and "ambulance 'amb'" in event.message()
    assert event.message().startswith("Observation (t = 2.0 s): ")
    assert detector.update(observation(3.0, near)) == []  # said once
    other_road = emergency("amb2", "behind", 10.0, relative_lane=None, type_id="")
    assert detector.update(observation(3.5, near, other_road)) == []  # not on the ego's road; amb still behind
    alongside = emergency("amb", "alongside", 0.0)
    assert detector.update(observation(5.0, alongside)) == []
    just_ahead = emergency("amb", "ahead", 8.0)
    assert detector.update(observation(6.0, just_ahead)) == []  # ahead, but less than 10 m
    ahead = emergency("amb", "ahead", 12.0)
    (event,) = detector.update(observation(9.0, ahead))
    assert event.kind == "emergency_vehicle_passed" and event.distance_m == 12.0
    assert "has passed us; it is now 12 m ahead" in event.message()
    assert detector.first_times_s == {"emergency_vehicle_approaching": 2.0, "emergency_vehicle_passed": 9.0}
    assert detector.update(observation(10.0, ahead)) == []  # said once


def test_an_emergency_vehicle_that_leaves_the_world_has_passed():
    detector = EmergencyDetector(alert_distance_m=50.0)
    assert detector.update(observation(1.0, emergency("amb", "behind", 60.0))) == []  # beyond this alert distance
    (approaching,) = detector.update(observation(2.0, emergency("amb", "behind", 40.0)))
    assert approaching.kind == "emergency_vehicle_approaching"
    (passed,) = detector.update(observation(3.0))
    assert passed.kind == "emergency_vehicle_passed" and passed.distance_m is None
    assert "has passed us; it is out of sight" in passed.message()


def test_the_label_falls_back_to_the_vehicle_class():
    detector = EmergencyDetector()
    (event,) = detector.update(observation(1.0, emergency("p1", "behind", 30.0, type_id="")))
    assert "(emergency 'p1')" in event.message()


def test_an_emergency_vehicle_ahead_is_never_approaching():
    detector = EmergencyDetector()
    assert detector.update(observation(1.0, emergency("amb", "ahead", 20.0))) == []
    assert detector.update(observation(2.0)) == []  # nothing was announced: nothing passes
    assert detector.first_times_s == {}


def _drive(config: PlainConfig, duration_s: float, detector: EmergencyDetector) -> list:
    """Hold the ego's speed on its lane; feed every observation to the detector."""
    world = PlainWorld(config)
    throttle = throttle_for_steady_speed(float(world.ego_state[3]))
    events = detector.update(world.observation)
    while world.time_s < duration_s - 1e-9:
        events += detector.update(world.advance(0.0, throttle, 0.0))
    return events


def test_a_scripted_ambulance_in_the_next_lane_approaches_and_passes():
    ambulance = ScriptedVehicle(id="ambulance0", lane="left", x_m=None, desired_speed_mps=24.0, type_id="ambulance",
                                emergency=True, appear_at_s=0.5, behind_ego_m=100.0)
    detector = EmergencyDetector(alert_distance_m=80.0)
    events = _drive(PlainConfig(vehicles=(ambulance,)), 20.0, detector)
    assert [e.kind for e in events] == ["emergency_vehicle_approaching", "emergency_vehicle_passed"]
    # 100 m centre to centre is 95.75 m bumper to bumper; it closes at 24 - 15 = 9 m/s
    approaching, passed = events
    assert approaching.time_s == pytest.approx(0.5 + (95.75 - 80.0) / 9.0, abs=0.1)
    assert 79.0 < approaching.distance_m <= 80.0
    # passed once its rear is 10 m ahead of the ego's front: 100 + 4.25 + 10 m more than the ego
    assert passed.time_s == pytest.approx(0.5 + 114.25 / 9.0, abs=0.1)
    assert 10.0 <= passed.distance_m < 10.5
    assert passed.vehicles == ("ambulance 'ambulance0'",)


def test_an_ambulance_held_up_behind_the_ego_never_passes():
    ambulance = ScriptedVehicle(id="ambulance0", lane="center", x_m=None, desired_speed_mps=24.0,
                                type_id="ambulance", emergency=True, appear_at_s=0.0, behind_ego_m=60.0)
    detector = EmergencyDetector()
    events = _drive(PlainConfig(vehicles=(ambulance,)), 20.0, detector)
    assert [e.kind for e in events] == ["emergency_vehicle_approaching"]
    assert events[0].time_s == 0.0  # within the alert distance from the start


def test_every_event_is_kept_in_order_and_read_back_from_its_json():
    # the agent's observation messages are these events as sumo://emergency-vehicles lists them
    detector = EmergencyDetector()
    detector.update(observation(2.0, emergency("amb", "behind", 60.123456)))
    detector.update(observation(9.0))  # it left the world
    assert [e.kind for e in detector.events] == ["emergency_vehicle_approaching", "emergency_vehicle_passed"]
    read = [EmergencyEvent.from_json(e.to_json()) for e in detector.events]
    assert [e.message() for e in read] == [e.message() for e in detector.events]
    assert read[0].distance_m == 60.123 and read[1].distance_m is None
    with pytest.raises(ValueError, match="not an emergency-vehicle event"):
        EmergencyEvent.from_json({"kind": "siren", "time_s": 1.0, "vehicles": [], "distance_m": None})
