"""Rescue lanes (sublane model + bluelight device), the ego's lateral sign in both handednesses, and the ego's
insertion into dense traffic. Real SUMO (libsumo), one simulation at a time."""

from __future__ import annotations

import math

import libsumo
import pytest
from pydantic import ValidationError

from agentic_mpc.sumo.config import RescueLanes, SumoConfig, VehicleSpawn
from agentic_mpc.sumo.insertion import free_spots
from agentic_mpc.sumo.route_files import rescue_lanes_active
from agentic_mpc.sumo.scenarios import net_files, nets_dir, scenario2_config
from agentic_mpc.sumo.start import open_bridge
from agentic_mpc.sumo.world import SumoWorld

WALL_SPEED_MPS = 15.0


def curvy_empty(lefthand: bool, **update: object) -> SumoConfig:
    net, _ = net_files("curvy", lefthand)
    return SumoConfig(net_file=net, route_files=(nets_dir() / "curvy_empty.rou.xml",), road="curvy", **update)


def wall_time_loss_s(lefthand: bool, rescue: bool, seed: int = 0) -> float:
    """No ego: 3 cars abreast at 15 m/s (60 m from the start) ahead of an ambulance (10 m, centre lane, 20 m/s)
    on the curved 3-lane road; the ambulance's SUMO time loss when it reaches the road's end."""
    config = curvy_empty(lefthand, rescue_lanes=RescueLanes(enabled=rescue))
    with open_bridge(config, seed, 0.04, lefthand) as bridge:
        bridge.add_route("r", ["curvy"])
        for lane in range(3):
            bridge.add_vehicle(f"wall{lane}", "r", "car", lane_index=lane, pos_m=60.0, speed_mps=WALL_SPEED_MPS)
            bridge.configure_vehicle(f"wall{lane}", max_speed_mps=WALL_SPEED_MPS, speed_factor=1.0, imperfection=0.0)
        bridge.add_vehicle("ambulance", "r", "ambulance", lane_index=1, pos_m=10.0, speed_mps=20.0)
        loss = math.nan
        for _ in range(round(300 / 0.04)):
            bridge.step()
            if "ambulance" in bridge.arrived:
                return loss
            if bridge.has_vehicle("ambulance"):
                loss = bridge.time_loss_s("ambulance")
    raise AssertionError("the ambulance did not reach the road's end in 300 s")


@pytest.mark.parametrize("lefthand", [False, True], ids=["right-hand", "left-hand"])
def test_rescue_lane_opens_a_wall_of_cars(lefthand, report):
    on = wall_time_loss_s(lefthand, rescue=True)
    off = wall_time_loss_s(lefthand, rescue=False)
    report(f"wall, {'left' if lefthand else 'right'}-hand: ambulance time loss {off:.1f} s off, {on:.1f} s on")
    assert on <= 3.0
    assert off >= 30.0  # stuck behind the wall for (nearly) the whole road


def test_rescue_lanes_default_follows_the_emergency_vehicles():
    plain = curvy_empty(False)
    assert not rescue_lanes_active(plain)
    with_ambulance = plain.replace(vehicles=(VehicleSpawn(id="a", type_id="ambulance", pos_m=10.0),))
    assert rescue_lanes_active(with_ambulance)
    assert not rescue_lanes_active(with_ambulance.replace(rescue_lanes=RescueLanes(enabled=False)))
    assert rescue_lanes_active(plain.replace(rescue_lanes=RescueLanes(enabled=True)))
    # background traffic of cars and trucks only: off; the paper's Scenario 2 has an ambulance: on
    net, routes = net_files("curvy")
    assert not rescue_lanes_active(SumoConfig(net_file=net, route_files=(routes,), road="curvy"))
    assert rescue_lanes_active(scenario2_config(roadblock=False))
    assert not rescue_lanes_active(scenario2_config())  # the pinned cars are the paper's controlled setting


def test_unknown_bluelight_parameters_are_refused():
    with pytest.raises(ValidationError, match="unknown bluelight parameters"):
        RescueLanes(emergency_params={"device.bluelight.reaction-prob": 1.0})
    with pytest.raises(ValidationError, match="mingapfactor must stay 1"):
        RescueLanes(emergency_params={"device.bluelight.mingapfactor": 0.5})
    assert RescueLanes(emergency_params={"device.bluelight.near-dist": 20.0}).emergency_params


def test_world_starts_sumo_with_the_rescue_lane_settings():
    config = scenario2_config(lefthand=False, roadblock=False)
    with SumoWorld(config) as world:
        assert world.rescue_lanes
        command = world.bridge.command
        assert command[command.index("--lateral-resolution") + 1] == "0.4"
        assert command[command.index("--device.bluelight.reactiondist") + 1] == "100.0"
        assert libsumo.vehicletype.getParameter("ambulance", "device.bluelight.reaction-prob-far") == "1.0"
    with SumoWorld(config.replace(rescue_lanes=RescueLanes(enabled=False))) as world:
        assert not world.rescue_lanes
        assert "--lateral-resolution" not in world.bridge.command
        assert "--device.bluelight.reactiondist" not in world.bridge.command


# --- the ego's lateral position as SUMO sees it ------------------------------------------------------------
@pytest.mark.parametrize("lefthand", [False, True], ids=["right-hand", "left-hand"])
def test_ego_held_left_of_its_lane_is_left_for_sumo(lefthand):
    """SUMO's sign convention for the lateral lane position differs between handednesses; whatever it is, the
    ego held 1 m left of its lane centre must carry the sign SUMO gives its own car left of its lane."""
    config = scenario2_config(lefthand=lefthand, roadblock=False, rescue_lanes=RescueLanes(enabled=False),
                              sublane=True, vehicles=())
    with SumoWorld(config) as world:
        bridge = world.bridge
        bridge.add_vehicle("car", "road_from_emergency", "car", lane_index=1, pos_m=260.0, speed_mps=15.0)
        bridge.configure_vehicle("car", max_speed_mps=15.0, speed_factor=1.0, imperfection=0.0)
        bridge.step()
        x, y, phi, v = world.ego_state
        assert phi == pytest.approx(0.0)  # the emergency road runs straight along +x
        ego_lane = world.road.lane_index("center")
        for step in range(100):
            if step == 60:
                libsumo.vehicle.changeSublane("car", 1.0)  # some direction: we find out which below
            # hold the ego 1 m left of its lane centre, driving straight along the lane at v
            x += v * 0.04
            y += 1.0 - world.lateral_offset_m(ego_lane, x, y)
            bridge.move_external("ego", x, y, phi, speed_mps=v)
            bridge.step()
        assert world.lateral_offset_m(ego_lane, x, y) == pytest.approx(1.0, abs=1e-6)
        ego_sumo = libsumo.vehicle.getLateralLanePosition("ego")
        car_sumo = libsumo.vehicle.getLateralLanePosition("car")
        x_car, y_car = libsumo.vehicle.getPosition("car")
        car_physical_side = math.copysign(1.0, world.lateral_offset_m(ego_lane, x_car, y_car))
        assert abs(car_sumo) > 0.3 and abs(ego_sumo) == pytest.approx(1.0, abs=0.05)
        # SUMO's sign for "left" is the car's sign times the side it physically is on
        assert math.copysign(1.0, ego_sumo) == math.copysign(1.0, car_sumo) * car_physical_side
        assert (ego_sumo < 0) == lefthand  # measured: in left-hand nets SUMO counts left as negative
        # and what the bridge reads back is in our convention (+ left) and exactly where we put the ego
        state = bridge.vehicle_state("ego")
        assert state.lateral_offset_m == pytest.approx(1.0, abs=0.05)
        assert (state.x_m, state.y_m) == pytest.approx((x, y), abs=1e-6)
        car = bridge.vehicle_state("car")
        assert math.copysign(1.0, car.lateral_offset_m) == car_physical_side


# --- the ego gets in ----------------------------------------------------------------------------------------
def test_free_spots_nearest_first_and_safe():
    vehicles = [(40.0, 4.5, 2.5, 15.0), (100.0, 4.5, 2.5, 15.0), (300.0, 12.0, 3.0, 10.0)]
    spots = free_spots(vehicles, 600.0, 30.0, 5.2, 2.5, 15.0)
    assert spots == sorted(spots, key=lambda p: abs(p - 30.0))
    for spot in spots:
        back = spot - 5.2
        for pos, length, min_gap, speed in vehicles:
            if pos < spot:  # a follower: its minGap and at least a second at its speed behind our back
                assert back - pos >= min_gap + speed
            else:  # a leader: our minGap and at least a second at our speed behind its back
                assert pos - length - spot >= 2.5 + 15.0
    assert free_spots([], 600.0, 30.0, 5.2, 2.5, 15.0) == [30.0]
    # bumper to bumper: no gap anywhere
    packed = [(float(p), 4.5, 2.5, 15.0) for p in range(10, 600, 8)]
    assert free_spots(packed, 600.0, 30.0, 5.2, 2.5, 15.0) == []


def test_ego_enters_dense_traffic_at_the_nearest_free_gap():
    """After the warm-up of the dense sweep (seed 5001) the requested spot stays occupied: SUMO used to give up
    ("did not insert 'ego' ... within 250 steps"); now the ego enters the nearest free gap of its lane."""
    net, _ = net_files("curvy")
    config = SumoConfig(net_file=net, route_files=(nets_dir() / "curvy_dense.rou.xml",), road="curvy",
                        warmup_s=90.0)
    with SumoWorld(config, seed=5001) as world:
        start = world.ego_start
        assert start["requested_pos_m"] == 30.0
        assert start["pos_m"] != 30.0 and 30.0 < start["pos_m"] < 400.0
        assert start["inserted_at_s"] > start["requested_at_s"]
        ego = world.bridge.vehicle_state("ego")
        assert ego.lane_index == start["lane_index"]
        # SUMO has the ego where the world says (its model state), on the chosen spot
        x, y, _, _ = world.ego_state
        assert (ego.x_m, ego.y_m) == pytest.approx((x, y), abs=1e-6)
        assert world.observation.ego.lane_role == "center"
    with SumoWorld(config.replace(warmup_s=0.0), seed=5001) as world:  # a free road: the requested spot
        assert world.ego_start["pos_m"] == 30.0
