"""SUMO's drivers and the ego's intentions: followers open a gap for a lane change the ego's plan announces, and
drivers an ambulance has passed leave its rescue lane. Real SUMO (libsumo), one simulation at a time."""

from __future__ import annotations

import libsumo
import numpy as np

from agentic_mpc.sumo.config import EgoStart, RescueLanes, SumoConfig
from agentic_mpc.sumo.intention import GapRequest, IntentionReader
from agentic_mpc.sumo.scenarios import net_files, nets_dir
from agentic_mpc.sumo.start import open_bridge
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.vehicle import throttle_for_steady_speed

EGO_SPEED_MPS = 10.0


def curvy_empty(**update: object) -> SumoConfig:
    net, _ = net_files("curvy", False)
    return SumoConfig(net_file=net, route_files=(nets_dir() / "curvy_empty.rou.xml",), road="curvy", **update)


def plan_towards(world: SumoWorld, lateral_m: float, steps: int = 50) -> np.ndarray:
    """A plan along the ego's lane at its speed that ends ``lateral_m`` to its left (straight road part)."""
    x, y, phi, v = world.ego_state
    k = np.arange(1, steps + 1)
    along = v * world.dt_s * k
    side = lateral_m * k / steps
    return np.stack([x + along * np.cos(phi) - side * np.sin(phi), y + along * np.sin(phi) + side * np.cos(phi)], 1)


def follower_overtakes(announce: bool) -> float:
    """The ego drives at 10 m/s in the centre lane with its plan going 2.5 m left; a car 25 m behind it in the
    left lane at 15 m/s. Returns the car's lead over the ego after 8 s (m)."""
    config = curvy_empty(ego=EgoStart(lane="center", pos_m=60.0, speed_mps=EGO_SPEED_MPS),
                         announce_lane_changes=announce)
    with SumoWorld(config) as world:
        bridge = world.bridge
        bridge.add_route("r", ["curvy"])
        bridge.add_vehicle("car", "r", "car", lane_index=2, pos_m=35.0, speed_mps=15.0)
        bridge.configure_vehicle("car", max_speed_mps=15.0, speed_factor=1.0, imperfection=0.0,
                                 lane_change_mode=0)
        throttle = throttle_for_steady_speed(EGO_SPEED_MPS)
        for step in range(200):
            if step % 5 == 0:
                world.signal_intention(plan_towards(world, 2.5))
            world.advance(0.0, throttle, 0.0)
        ego_s = libsumo.vehicle.getLanePosition("ego")
        return libsumo.vehicle.getLanePosition("car") - ego_s


def test_a_follower_opens_a_gap_for_the_lane_change_the_plan_announces(report):
    lead_told = follower_overtakes(announce=True)
    lead_not_told = follower_overtakes(announce=False)
    report(f"car 25 m behind in the left lane, 8 s later: {lead_not_told:+.1f} m ahead of the ego untold,"
           f" {lead_told:+.1f} m told")
    assert lead_not_told > 10.0  # at 15 against 10 m/s it passes
    assert lead_told < -5.0  # it kept a gap behind the ego instead


def test_a_standing_ego_that_sticks_out_announces_nothing():
    config = curvy_empty(ego=EgoStart(lane="center", pos_m=60.0, speed_mps=0.0, lateral_offset_m=1.2))
    with SumoWorld(config) as world:
        reader = IntentionReader(world.road, world.ego_width_m)
        x, y = world.ego_state[:2]
        standing = np.tile([x, y], (50, 1))
        assert reader.read(world.observation, standing).lane_index is None
        left = reader.read(world.observation, plan_towards(world, 1.5))
        right = reader.read(world.observation, plan_towards(world, -3.0))
        assert (left.side, left.lane_index) == ("left", world.road.lane_index("left"))
        assert (right.side, right.lane_index) == ("right", world.road.lane_index("right"))
        assert reader.read(world.observation, plan_towards(world, 0.2)).lane_index is None  # less than 0.3 m more


def drivers_after_an_ambulance(release: bool) -> list[tuple[int, float]]:
    """No ego: four cars in the centre lane at 10 m/s, an ambulance coming up behind them at 20 m/s. Returns each
    car's (lane-change mode, lcStrategic) 30 s later, when the ambulance is far ahead but still on the road."""
    config = curvy_empty(rescue_lanes=RescueLanes(enabled=True))
    with open_bridge(config, 0, 0.04) as bridge:
        bridge.add_route("r", ["curvy"])
        for i in range(4):
            bridge.add_vehicle(f"car{i}", "r", "car", lane_index=1, pos_m=150.0 - 20.0 * i, speed_mps=10.0)
            bridge.configure_vehicle(f"car{i}", max_speed_mps=10.0, speed_factor=1.0, imperfection=0.0)
        bridge.add_vehicle("ambulance", "r", "ambulance", lane_index=1, pos_m=10.0, speed_mps=20.0)
        released = set()
        for step in range(round(30 / 0.04)):
            bridge.step()
            if release and step % 25 == 0:
                released.update(bridge.release_rescue_lanes(100.0, {"car": 0.5}))
        assert bridge.has_vehicle("ambulance")
        assert released == ({f"car{i}" for i in range(4)} if release else set())
        return [
            (libsumo.vehicle.getLaneChangeMode(f"car{i}"),
             float(libsumo.vehicle.getParameter(f"car{i}", "laneChangeModel.lcStrategic")))
            for i in range(4)
        ]


def test_drivers_the_ambulance_has_passed_drive_normally_again(report):
    held = drivers_after_an_ambulance(release=False)
    released = drivers_after_an_ambulance(release=True)
    report(f"30 s after an ambulance passed them: SUMO holds {held[0]}, released {released[0]}")
    # SUMO's device: no strategic and no speed-gain lane changes while the ambulance is on their (1.6 km) edge
    assert all(mode == 1605 and strategic == -1.0 for mode, strategic in held)
    # released: SUMO's default mode and the route file's lcStrategic (given here as 0.5)
    assert all(mode == 1621 and strategic == 0.5 for mode, strategic in released)


def released_behind_a_stopped_car(blocked_within_m: float | None, ambulance_stands: bool) -> tuple[set[str], float]:
    """No ego: three cars in the centre lane drive up to a stopped car, an ambulance comes up behind them (or
    stands 50 m behind the last: held at 0 m/s). Returns the drivers released in the first 12 s (a passing
    ambulance is then about 50 m past the first car, inside the 100 m after which a driver is let go) and how
    far the first car is along the lane 20 s in."""
    config = curvy_empty(rescue_lanes=RescueLanes(enabled=True), sublane=True)
    with open_bridge(config, 0, 0.04) as bridge:
        bridge.add_route("r", ["curvy"])
        bridge.add_stopped_vehicle("stopped", "r", "car", edge_id="curvy", lane_index=1, pos_m=300.0)
        for i in range(3):
            bridge.add_vehicle(f"car{i}", "r", "car", lane_index=1, pos_m=230.0 - 15.0 * i, speed_mps=8.0)
        bridge.add_vehicle("ambulance", "r", "ambulance", lane_index=1, pos_m=150.0 if ambulance_stands else 120.0,
                           speed_mps=0.0 if ambulance_stands else 20.0)
        released: set[str] = set()
        early: set[str] = set()
        for step in range(round(20 / 0.04)):
            if ambulance_stands:
                libsumo.vehicle.setSpeed("ambulance", 0.0)
            bridge.step()
            if step % 25 == 0:
                released.update(bridge.release_rescue_lanes(100.0, {"car": 1.0}, blocked_within_m))
            if step == round(12 / 0.04):
                early = set(released)
        return early, libsumo.vehicle.getLanePosition("car0")


def test_a_driver_standing_behind_a_stopped_car_is_released_while_the_ambulance_stands_too():
    """Behind a stopped car SUMO's device keeps a driver from changing lanes until the ambulance is 100 m past;
    an ambulance stuck behind that driver never is, and the queue waited for good (seed 901). With both
    standing the driver is released at once and is on its way sooner; with the ambulance coming up it is not
    (released then, drivers pulled out into the ambulance's way)."""
    held, held_at_m = released_behind_a_stopped_car(None, ambulance_stands=True)
    early, early_at_m = released_behind_a_stopped_car(15.0, ambulance_stands=True)
    assert held == set() and early == {"car0"}
    assert early_at_m > held_at_m + 30.0
    passing, _ = released_behind_a_stopped_car(15.0, ambulance_stands=False)
    assert passing == set()


def car_after_passing_a_standing_ego(let_go: bool) -> float:
    """A car in the centre lane at 10 m/s asked once to open a gap behind an ego standing in the edge lane 10 m
    ahead; with ``let_go`` the request is ended 1 s later. Returns the car's speed 10 s on (m/s)."""
    config = curvy_empty(ego=EgoStart(lane="right", pos_m=70.0, speed_mps=0.0))
    with SumoWorld(config) as world:
        bridge = world.bridge
        bridge.add_route("r", ["curvy"])
        bridge.add_vehicle("car", "r", "car", lane_index=1, pos_m=60.0, speed_mps=10.0)
        bridge.step()
        bridge.open_gaps("ego", [GapRequest("car", 1.0, 2.5, 1.0, 2.0)])
        for step in range(250):
            if step == 25 and let_go:
                bridge.open_gaps("ego", [], end_for=["car"])
            world.advance(0.0, 0.0, 0.5)
        return libsumo.vehicle.getSpeed("car")


def test_followers_no_longer_asked_are_let_go(report):
    held = car_after_passing_a_standing_ego(let_go=False)
    let_go = car_after_passing_a_standing_ego(let_go=True)
    report(f"a car asked once to open a gap behind a standing ego, 10 s later: {held:.1f} m/s, let go {let_go:.1f} m/s")
    assert held < 0.5  # SUMO ends the gap control only once the gap is reached: it stood for good
    assert let_go > 8.0
