"""Rule ``wave_through``: in a junction, a car standing in the ego's way while the ego stands too is waved on once
both have stood ``after_s``; never a car beside the path, one on the ego's own lane, or while a line holds the ego."""

from __future__ import annotations

import dataclasses
import json
import math

from agentic_mpc.tactics.config import ALL_RULES, TacticsConfig
from agentic_mpc.tactics.layer import TacticalRoad, TacticsLayer
from agentic_mpc.world.observation import EgoObservation, JunctionAhead, Observation, VehicleObservation

EGO_LENGTH_M = 5.2
EGO_X_M = 100.0
ROAD = TacticalRoad((0.0,), EGO_LENGTH_M, 2.0, locate=lambda x, y, _guess: (x, y))
"""A straight road along x, its reference line y = 0: along-road position x, offset y."""


def car(x_m: float, y_m: float, heading_rad: float = math.pi / 2, speed_mps: float = 0.0,
        lane_s_m: float | None = None, vehicle_id: str = "osm27.3") -> VehicleObservation:
    return VehicleObservation(vehicle_id, "car", "passenger", x_m, y_m, heading_rad, speed_mps, 0.0, 0.0,
                              ":J_6_0", 0, "", ":J_6", 4.5, 1.8, x_m, x_m - EGO_X_M, x_m - EGO_X_M - 4.85, "ahead",
                              None, lane_s_m, 0.0, "", 0.0)


def seen(time_s: float, *traffic: VehicleObservation, ego_speed_mps: float = 0.0, line_m: float = -3.0,
         signal: str | None = None) -> Observation:
    ego = EgoObservation("ego", EGO_X_M, 0.0, 0.0, ego_speed_mps, ":J_2_0", 0, "center", ":J_2", EGO_X_M, 0.0,
                         EGO_LENGTH_M, 2.0)
    front = EGO_X_M + 0.5 * EGO_LENGTH_M
    junction = JunctionAhead("J", front + line_m, front + 20.0, line_m, "left", signal, False, False, None)
    return Observation(time_s, ego, tuple(traffic), (), (), (), (junction,))


def run(layer: TacticsLayer, *traffic: VehicleObservation, until_s: float = 5.0, **kwargs) -> list[str | None]:
    """The cars the plan waves on, a step each 0.5 s from t = 0."""
    return [layer.plan(seen(0.5 * k, *traffic, **kwargs), tracked_lane=0).wave_through
            for k in range(int(until_s / 0.5) + 1)]


def test_a_car_standing_across_the_path_is_waved_on_once_after_both_stood_the_rules_time():
    layer = TacticsLayer(TacticsConfig(), ROAD)
    waved = run(layer, car(107.0, 3.15))  # its rear end 0.9 m left of the path's centre: in the way
    assert waved.index("osm27.3") == 6 and waved.count("osm27.3") == 1  # at t = 3.0 s (after_s), and once
    row = layer.changes[-1]
    assert row["event"] == "waved_through" and json.loads(row["result"])["junction_id"] == "J"
    assert "waved osm27.3 through at junction J" in layer.situation()


def test_cars_not_in_the_way_and_waits_that_are_the_egos_are_not_waved_on():
    def waved(*traffic: VehicleObservation, **kwargs) -> set[str | None]:
        return set(run(TacticsLayer(TacticsConfig(), ROAD), *traffic, **kwargs))

    assert waved(car(107.0, 5.0)) == {None}  # beside the path: its body 2.75 m left of the centre line
    assert waved(car(107.0, 0.0, heading_rad=0.0, lane_s_m=107.0)) == {None}  # on the ego's lane: a leader
    assert waved(car(107.0, 3.15, speed_mps=3.0)) == {None}  # it drives
    assert waved(car(107.0, 3.15), ego_speed_mps=1.0) == {None}  # the ego drives
    assert waved(car(107.0, 3.15), line_m=20.0) == {None}  # the ego is not at a junction yet
    assert waved(car(107.0, 3.15), line_m=3.0, signal="red") == {None}  # the ego waits at its red light
    without = TacticsConfig(rules=tuple(rule for rule in ALL_RULES if rule != "wave_through"))
    assert set(run(TacticsLayer(without, ROAD), car(107.0, 3.15))) == {None}
    assert set(run(TacticsLayer(TacticsConfig(), TacticalRoad((0.0,), EGO_LENGTH_M, 2.0)), car(107.0, 3.15))) == {None}


def test_the_wait_is_counted_from_when_the_same_car_stands_in_the_way():
    layer = TacticsLayer(TacticsConfig(), ROAD)
    first = [layer.plan(seen(0.5 * k, car(107.0, 3.15, vehicle_id="a")), tracked_lane=0).wave_through
             for k in range(4)]  # 1.5 s with car a, then car b stands there
    second = [layer.plan(seen(2.0 + 0.5 * k, car(107.0, 3.15, vehicle_id="b")), tracked_lane=0).wave_through
              for k in range(7)]
    assert set(first) == {None} and second.index("b") == 6  # b's 3 s, not a's and b's together


def test_the_ego_stands_until_the_car_it_waved_on_is_out_of_its_way():
    layer = TacticsLayer(TacticsConfig(), ROAD)
    run(layer, car(107.0, 3.15), until_s=3.0)  # waved at t = 3 s
    front_s = EGO_X_M + 0.5 * EGO_LENGTH_M
    moving = layer.plan(seen(3.5, car(106.0, 3.15, heading_rad=math.pi, speed_mps=2.0)), tracked_lane=0)
    assert moving.speed_cap_mps == 0.0 and moving.stop_line_s_m == front_s  # it turns across: the ego stands
    assert "waiting for it to go first" in moving.junction_reason
    swinging = dataclasses.replace(car(103.0, 1.0, heading_rad=-1.0, speed_mps=3.0, lane_s_m=103.0),
                                   relation="alongside", gap_m=-1.9)  # on the ego's lane, still turning
    assert layer.plan(seen(3.8, swinging), tracked_lane=0).stop_line_s_m == front_s
    gone = layer.plan(seen(4.0, car(120.0, 3.15, heading_rad=0.0, speed_mps=4.0, lane_s_m=120.0)), tracked_lane=0)
    assert gone.stop_line_s_m is None and gone.speed_cap_mps is None  # ahead in the ego's lane: a leader now


def test_a_waved_car_standing_in_the_way_holds_the_ego_one_standing_beside_the_path_lets_it_go():
    layer = TacticsLayer(TacticsConfig(), ROAD)
    run(layer, car(107.0, 3.15), until_s=3.0)
    holds = [layer.plan(seen(3.0 + 0.5 * k, car(107.0, 3.15)), tracked_lane=0).stop_line_s_m is not None
             for k in range(1, 21)]
    assert all(holds)  # 10 s: it may set off any moment, across the ego (tuning seed 518: after 10 s)
    beside = layer.plan(seen(14.0, car(107.0, 5.0)), tracked_lane=0)  # it moved on and stopped beside the path
    assert beside.stop_line_s_m is None and beside.speed_cap_mps is None


def test_standing_in_a_junction_the_ego_does_not_set_off_while_a_car_moves_across_its_path():
    layer = TacticsLayer(TacticsConfig(), ROAD)
    across = layer.plan(seen(0.0, car(106.0, 1.0, heading_rad=-1.2, speed_mps=2.5)), tracked_lane=0)
    assert across.stop_line_s_m == EGO_X_M + 0.5 * EGO_LENGTH_M
    assert "osm27.3 to cross in front" in across.junction_reason
    assert layer.plan(seen(0.5, car(106.0, 1.0, heading_rad=-1.2, speed_mps=2.5), ego_speed_mps=3.0),
                      tracked_lane=0).stop_line_s_m is None  # moving, J0 brakes for it
    assert layer.plan(seen(1.0, car(106.0, 6.0, speed_mps=2.5)), tracked_lane=0).stop_line_s_m is None  # beside


def test_a_red_light_further_on_does_not_keep_the_ego_from_waiting_for_a_car_crossing_in_front():
    layer = TacticsLayer(TacticsConfig(), ROAD)
    crossing = car(106.0, 1.0, heading_rad=-1.2, speed_mps=2.5)
    ego = EgoObservation("ego", EGO_X_M, 0.0, 0.0, 0.0, "e_0", 0, "center", "e", EGO_X_M, 0.0, EGO_LENGTH_M, 2.0)
    red = JunctionAhead("K", 177.0, 190.0, 74.4, "straight", "red", False, False, None)
    plan = layer.plan(Observation(0.0, ego, (crossing,), (), (), (), (red,)), tracked_lane=0)
    assert plan.stop_line_s_m == EGO_X_M + 0.5 * EGO_LENGTH_M  # tuning seed 508: it crept into a U-turning car
