"""The per-step observation: relations to the ego, obstacles, collisions and the stable JSON form."""

from __future__ import annotations

import json
import math

import libsumo
import numpy as np
import pytest

from agentic_mpc.sumo.config import EgoStart, StaticObstacle, SumoConfig, VehicleSpawn
from agentic_mpc.sumo.scenarios import net_files, scenario2_config
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.world.observation import JSON_KEYS, Observation
from agentic_mpc.world.observation import boxes_overlap as _boxes_overlap
from tests.sumo.conftest import drive, sumo_loop

NET, ROUTES = net_files("straight")


def test_to_json_has_exactly_the_agreed_keys_and_is_json():
    with sumo_loop(scenario2_config(lefthand=True).replace(
        obstacles=(StaticObstacle(id="broken_down", lane="right", pos_m=400.0, in_j2=False),)
    ), stop_at_goal=False) as loop:
        drive(loop, 0.2)
        data = loop.world.observation.to_json()
    assert tuple(data) == JSON_KEYS == ("time_s", "ego", "traffic", "emergency_vehicles", "obstacles", "collisions")
    text = json.dumps(data)  # plain JSON types only
    assert json.loads(text) == data
    assert data["ego"]["id"] == "ego" and data["ego"]["lane_role"] == "center"
    assert {v["id"] for v in data["traffic"]} == {"ambulance", "block_left", "block_right"}
    (ambulance,) = data["emergency_vehicles"]
    assert ambulance["id"] == "ambulance" and ambulance["vclass"] == "emergency"
    assert ambulance["relation"] == "behind" and ambulance["distance_m"] > 0 and ambulance["closing_speed_mps"] > 0
    (obstacle,) = data["obstacles"]  # beyond sensing range (250 m ahead) but known: obstacles do not move
    assert obstacle["id"] == "broken_down" and obstacle["lane_role"] == "right" and obstacle["relation"] == "ahead"
    assert data["collisions"] == []


def test_relations_lanes_and_gaps_of_surrounding_vehicles():
    vehicles = (
        VehicleSpawn(id="ahead_same", lane="center", pos_m=130.0, speed_mps=15.0),
        VehicleSpawn(id="alongside_left", lane="left", pos_m=101.0, speed_mps=15.0),
        VehicleSpawn(id="behind_right", lane="right", pos_m=60.0, speed_mps=15.0),
    )
    config = SumoConfig(net_file=NET, route_files=(ROUTES,), road="straight", vehicles=vehicles,
                        ego=EgoStart(lane="center", pos_m=100.0, speed_mps=15.0))
    with SumoWorld(config) as world:
        observation = world.observation
        ego = observation.ego
        ahead, left, right = (observation.vehicle(i) for i in ("ahead_same", "alongside_left", "behind_right"))
        front = {i: world.bridge.vehicle_state(i).lane_pos_m for i in ("ego", "ahead_same", "behind_right")}
    assert (ahead.relation, ahead.relative_lane, ahead.lane_role) == ("ahead", 0, "center")
    # Straight road: bumper gaps from SUMO's front-bumper lane positions (car 4.5 m, ego 5.2 m long).
    assert ahead.gap_m == pytest.approx(front["ahead_same"] - 4.5 - front["ego"], abs=1e-6)
    assert ahead.offset_m == pytest.approx(ahead.x_m - ego.x_m, abs=1e-6)
    assert (left.relation, left.relative_lane, left.lane_role) == ("alongside", 1, "left")
    assert (right.relation, right.relative_lane, right.lane_role) == ("behind", -1, "right")
    assert right.gap_m == pytest.approx(front["ego"] - 5.2 - front["behind_right"], abs=1e-6)
    for vehicle in (ahead, left, right):
        assert (vehicle.vx_mps, vehicle.vy_mps) == pytest.approx((vehicle.speed_mps, 0.0), abs=1e-9)
        assert vehicle.vclass == "passenger" and vehicle.type_id == "car"
    assert (ego.lane_role, ego.edge_id, ego.lane_index) == ("center", "straight", 1)


def test_geometric_overlap_check():
    class Box:
        def __init__(self, x: float, y: float, heading: float, length: float = 4.5, width: float = 1.8) -> None:
            self.x_m, self.y_m, self.heading_rad, self.length_m, self.width_m = x, y, heading, length, width

    assert _boxes_overlap(Box(0, 0, 0), Box(4.4, 0, 0))
    assert not _boxes_overlap(Box(0, 0, 0), Box(4.6, 0, 0))
    assert not _boxes_overlap(Box(0, 0, 0), Box(0, 1.85, 0))
    assert _boxes_overlap(Box(0, 0, 0), Box(0, 1.75, 0))
    # Diagonal: corners near each other but separated along the rotated box's axis.
    assert not _boxes_overlap(Box(0, 0, 0), Box(3.9, 2.6, math.radians(45)))
    assert _boxes_overlap(Box(0, 0, 0), Box(3.0, 1.5, math.radians(45)))


def test_observation_is_frozen():
    with SumoWorld(SumoConfig(net_file=NET, route_files=(ROUTES,), road="straight")) as world:
        observation: Observation = world.observation
    with pytest.raises(AttributeError):
        observation.time_s = 1.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        observation.ego.x_m = 1.0  # type: ignore[misc]


@pytest.mark.parametrize("centre_lateral_offsets", [False, True])
def test_a_truck_changing_lanes_is_observed_where_its_body_is_and_covered_there(centre_lateral_offsets):
    """Under the sublane model SUMO moves a vehicle sideways and shows it turned; its lateral position is the
    front's, and at a crawl the back trails the front across the lanes. With ``centre_lateral_offsets`` the
    observation's lateral offset is the centre's and J0's discs sit on the body (incident seed 1406: without it
    they sat 0.8 m off a 12 m truck that had just changed lanes at 1 m/s, and the ego drove into the part they
    left out, and it is the default); without it the offset is SUMO's (docs/traffic.md)."""
    truck = VehicleSpawn(id="truck", type_id="truck", lane="left", pos_m=110.0, speed_mps=1.0, lane_changes=False)
    config = SumoConfig(net_file=NET, route_files=(ROUTES,), road="straight", sublane=True, vehicles=(truck,),
                        ego=EgoStart(lane="right", pos_m=100.0, speed_mps=1.0),
                        centre_lateral_offsets=centre_lateral_offsets)
    with SumoWorld(config) as world:
        libsumo.vehicle.changeLane("truck", 1, 10.0)  # into the centre lane, next to the ego's
        while world.observation.vehicle("truck").lane_role != "center" and world.time_s < 10.0:
            world.advance(0.0, 0.0, 0.0)
        seen = world.observation.vehicle("truck")
        front_lateral_m = libsumo.vehicle.getLateralLanePosition("truck")
        centre_lateral_m = world.lateral_offset_m(seen.lane_index, seen.x_m, seen.y_m)
        discs = [d for d in world.surroundings(30, None).moving_discs
                 if math.hypot(d.centres[0][0] - seen.x_m, d.centres[0][1] - seen.y_m) < 0.5 * seen.length_m + 3.0]
    assert seen.lane_role == "center" and seen.heading_rad < -0.05  # turned toward its new lane
    # The centre trails the front by half the length times the angle: 0.7 m toward the old lane.
    assert centre_lateral_m == pytest.approx(front_lateral_m - 6.0 * math.sin(seen.heading_rad), abs=0.05)
    assert centre_lateral_m - front_lateral_m > 0.5
    assert discs, "the truck has discs"
    row_middle = np.mean([d.centres[0] for d in discs], axis=0)  # stage 0: one step ahead, along the road
    if not centre_lateral_offsets:
        assert seen.lateral_offset_m == pytest.approx(front_lateral_m, abs=1e-6)
        assert row_middle[1] == pytest.approx(seen.y_m - (centre_lateral_m - front_lateral_m), abs=0.05)
        return
    assert seen.lateral_offset_m == pytest.approx(centre_lateral_m, abs=1e-6)
    assert row_middle[1] == pytest.approx(seen.y_m, abs=0.05)  # the straight road runs along x
    assert row_middle[0] == pytest.approx(seen.x_m, abs=0.5)
