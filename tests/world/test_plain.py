"""The plain-Python world: scripted traffic, obstacles, lanes and its configuration's checks."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from agentic_mpc.vehicle import throttle_for_steady_speed
from agentic_mpc.world.base import World, WorldError
from agentic_mpc.world.observation import JSON_KEYS
from agentic_mpc.world.plain import PlainWorld
from agentic_mpc.world.plain_config import EgoPlacement, PlainConfig, PlainObstacle, PlainRoad, ScriptedVehicle


def hold_speed(world: PlainWorld, until_s: float) -> list:
    """Drive straight on at the ego's speed until ``until_s``; the observations after each step."""
    throttle = throttle_for_steady_speed(float(world.ego_state[3]))
    seen = []
    while world.time_s < until_s - 1e-9:
        seen.append(world.advance(0.0, throttle, 0.0))
    return seen


def test_a_plain_world_is_a_world():
    world = PlainWorld()
    assert isinstance(world, World)
    assert set(world.observation.to_json()) == set(JSON_KEYS)
    assert world.time_s == 0.0 and list(world.ego_state) == [0.0, 0.0, 0.0, 15.0]


def test_a_faster_car_behind_keeps_its_gap_to_the_ego():
    car = ScriptedVehicle(id="car0", lane="center", x_m=-40.0, desired_speed_mps=25.0)
    world = PlainWorld(PlainConfig(vehicles=(car,)))
    seen = hold_speed(world, 30.0)
    cars = [o.vehicle("car0") for o in seen]
    assert all(c is not None and c.relation == "behind" and c.gap_m > 2.0 for c in cars)
    assert not any(o.collisions for o in seen)
    last = cars[-1]
    assert last.speed_mps == pytest.approx(world.ego_state[3], abs=0.5)  # it follows at the ego's speed
    assert last.relative_lane == 0 and last.lane_role == "center"


def test_a_car_in_another_lane_drives_at_its_own_speed():
    car = ScriptedVehicle(id="car0", lane="right", x_m=60.0, desired_speed_mps=11.0)
    world = PlainWorld(PlainConfig(vehicles=(car,)))
    hold_speed(world, 10.0)
    seen = world.observation.vehicle("car0")
    assert seen.speed_mps == pytest.approx(11.0)
    assert seen.x_m == pytest.approx(60.0 + 11.0 * 10.0, abs=0.5) and seen.relative_lane == -1


def test_an_ambulance_appears_behind_the_ego_when_its_time_comes():
    ambulance = ScriptedVehicle(id="ambulance0", lane="center", x_m=None, desired_speed_mps=22.0,
                                type_id="ambulance", emergency=True, appear_at_s=2.0, behind_ego_m=70.0)
    world = PlainWorld(PlainConfig(vehicles=(ambulance,)))
    seen = hold_speed(world, 4.0)
    before = [o for o in seen if not o.emergency_vehicles]
    first = next(o for o in seen if o.emergency_vehicles)
    assert before and all(o.time_s <= 2.0 + world.dt_s + 1e-9 for o in before) and not any(o.traffic for o in before)
    assert 2.0 <= first.time_s <= 2.0 + 2 * world.dt_s
    (emergency,) = first.emergency_vehicles
    assert emergency.relation == "behind" and emergency.same_lane
    # placed 70 m behind the ego when it appeared, then it drove its first step
    assert emergency.vehicle.offset_m == pytest.approx(-70.0 + 22.0 * world.dt_s, abs=0.05)
    assert emergency.closing_speed_mps == pytest.approx(22.0 - 15.0, abs=0.1)
    assert emergency.vehicle.type_id == "ambulance" and emergency.vehicle.vclass == "emergency"


def test_an_ambulance_at_time_zero_is_there_from_the_start():
    ambulance = ScriptedVehicle(id="ambulance0", lane="center", x_m=None, desired_speed_mps=22.0, emergency=True,
                                behind_ego_m=50.0)
    world = PlainWorld(PlainConfig(ego=EgoPlacement(x_m=100.0), vehicles=(ambulance,)))
    (emergency,) = world.observation.emergency_vehicles
    assert emergency.vehicle.x_m == 50.0 and emergency.distance_m == pytest.approx(50.0 - 0.5 * (4.0 + 4.5))


def test_driving_into_an_obstacles_circle_is_a_collision():
    obstacle = PlainObstacle(id="cone", x_m=20.0, y_m=0.0, radius_m=2.0)
    world = PlainWorld(PlainConfig(obstacles=(obstacle,)))
    seen = hold_speed(world, 2.0)
    hits = [o for o in seen if o.collisions]
    assert hits and not seen[0].collisions
    first = hits[0]
    assert first.ego_collided and first.collisions[0].victim == "cone" and first.collisions[0].collider == "ego"
    assert 18.0 - 15.0 * world.dt_s <= first.ego.x_m <= 18.0 + 15.0 * world.dt_s  # at the circle's edge
    (seen_obstacle,) = first.obstacles
    assert (seen_obstacle.id, seen_obstacle.length_m) == ("cone", 4.0)


def test_passing_an_obstacle_in_the_next_lane_is_no_collision():
    obstacle = PlainObstacle(id="cone", x_m=20.0, y_m=3.5, radius_m=2.0, in_j2=False)
    world = PlainWorld(PlainConfig(obstacles=(obstacle,)))
    assert not any(o.collisions for o in hold_speed(world, 3.0))
    assert world.obstacle_circles()[0].label == "cone" and world.obstacle_circles(only_in_j2=True) == ()


@pytest.mark.parametrize(("lefthand", "by_index"), [(False, ("right", "center", "left")),
                                                     (True, ("left", "center", "right"))])
def test_lanes_by_role_and_by_index(lefthand, by_index):
    world = PlainWorld(PlainConfig(road=PlainRoad(lane_width_m=3.0, speed_limit_mps=20.0, lefthand=lefthand)))
    lanes = world.lanes()
    assert set(lanes.lanes) == {"center", "left", "right"}
    assert (lanes.speed_limit_mps, lanes.lefthand) == (20.0, lefthand)
    assert [float(lanes.lanes[role].coordinates[0][1]) for role in ("center", "left", "right")] == [0.0, 3.0, -3.0]
    for index, role in enumerate(by_index):
        assert world.lane(index) == (role, lanes.lanes[role])
        assert world.lane(role)[0] == role and world.lane_index_of(lanes.lanes[role]) == index
    with pytest.raises(WorldError, match="no lane 'shoulder'"):
        world.lane("shoulder")
    with pytest.raises(WorldError, match="no lane 3"):
        world.lane(3)
    assert world.observation.ego.lane_role == "center" and world.observation.ego.lane_index == 1


def test_the_ego_starts_in_its_lane():
    world = PlainWorld(PlainConfig(ego=EgoPlacement(lane="left", speed_mps=10.0)))
    assert list(world.ego_state) == [0.0, 3.5, 0.0, 10.0]
    assert world.observation.ego.lane_role == "left"


@pytest.mark.parametrize(
    ("config", "message"),
    [
        (PlainConfig(goal_s_m=30_000.0), "goal_s_m=30000.0 is not on the road"),
        (PlainConfig(ego=EgoPlacement(x_m=-500.0)), "the ego's start x_m=-500.0 is off the road"),
    ],
)
def test_a_world_that_cannot_start_is_a_world_error(config, message):
    with pytest.raises(WorldError, match=message):
        PlainWorld(config)


@pytest.mark.parametrize(
    "build",
    [
        lambda: PlainConfig(vehicles=(ScriptedVehicle(id="ego", lane="left", x_m=0.0, desired_speed_mps=1.0),)),
        lambda: PlainConfig(obstacles=(PlainObstacle(id="a", x_m=1.0), PlainObstacle(id="a", x_m=2.0))),
        lambda: ScriptedVehicle(id="car", lane="shoulder", x_m=0.0, desired_speed_mps=10.0),
        lambda: ScriptedVehicle(id="car", lane="left", x_m=0.0, desired_speed_mps=-1.0),
        lambda: PlainObstacle(id="cone", x_m=1.0, radius_m=0.0),
        lambda: PlainRoad(lane_width_m=0.0),
        lambda: EgoPlacement(speed_mps=float("nan")),
        lambda: PlainConfig(gravity=9.81),
    ],
)
def test_bad_configurations_are_refused(build):
    with pytest.raises(ValidationError):
        build()
