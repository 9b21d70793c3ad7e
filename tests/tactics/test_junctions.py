"""The junction rules: a stop for red and for a yellow the ego can stop at comfortably, a stop sign, giving way
only until a gap, the route's slower stretches, and what the plan shows of them."""

from __future__ import annotations

import math

import pytest

from agentic_mpc.tactics.config import TacticsConfig
from agentic_mpc.tactics.junctions import JunctionRules
from agentic_mpc.tactics.layer import TacticalRoad, TacticsLayer
from agentic_mpc.world.observation import EgoObservation, JunctionAhead, Observation

EGO_LENGTH_M = 5.2


def observation(speed_mps: float, *junctions: JunctionAhead, road_s_m: float = 100.0, time_s: float = 0.0
                ) -> Observation:
    ego = EgoObservation("ego", road_s_m, 0.0, 0.0, speed_mps, "e_0", 0, "center", "e", road_s_m, 0.0,
                         EGO_LENGTH_M, 2.0)
    return Observation(time_s, ego, (), (), (), (), tuple(junctions))


def junction(distance_m: float, signal: str | None = None, *, must_yield: bool = False, stop_sign: bool = False,
             foe_arrival_s: float | None = None, front_s_m: float = 102.6) -> JunctionAhead:
    stop = front_s_m + distance_m
    return JunctionAhead("J", stop, stop + 20.0, distance_m, "straight", signal, must_yield, stop_sign, foe_arrival_s)


def decide(rules: JunctionRules, speed_mps: float, *junctions: JunctionAhead, time_s: float = 0.0):
    return rules.decide(observation(speed_mps, *junctions, time_s=time_s), EGO_LENGTH_M)


def test_red_stops_the_ego_at_the_line_and_green_lets_it_go():
    rules = JunctionRules(TacticsConfig())
    red = decide(rules, 12.0, junction(40.0, "red"))
    config = TacticsConfig().traffic_lights
    assert red.stop_line_s_m == pytest.approx(142.6)
    assert red.speed_cap_mps == pytest.approx(math.sqrt(2 * config.stop_decel_mps2 * (40.0 - config.stop_margin_m)))
    assert "red light at junction J" in red.reason
    assert decide(rules, 12.0, junction(0.5, "red")).speed_cap_mps == 0.0  # at the line: standing
    green = decide(rules, 12.0, junction(40.0, "green"))
    assert green.stop_line_s_m is None and green.speed_cap_mps is None and green.reason is None
    inside = decide(rules, 5.0, junction(-3.0, "red"))  # its front already in the junction: it clears it
    assert inside.stop_line_s_m is None


def test_yellow_stops_the_ego_only_where_a_comfortable_stop_is_possible():
    assert decide(JunctionRules(TacticsConfig()), 12.0, junction(30.0, "yellow")).stop_line_s_m is not None  # 2.4
    assert decide(JunctionRules(TacticsConfig()), 12.0, junction(20.0, "yellow")).stop_line_s_m is None  # 3.6: go


def test_a_yellow_the_ego_could_stop_for_when_it_came_holds_it_until_the_light_changes():
    """Judged anew each step, the stop let go once the ego, braking gently at first, needed a little more than the
    rate; it then went through on yellow (junction_osm_route seed 308)."""
    rules = JunctionRules(TacticsConfig())
    assert decide(rules, 12.0, junction(30.0, "yellow")).stop_line_s_m is not None  # 2.4 m/s^2 when it came
    assert decide(rules, 11.5, junction(20.0, "yellow")).reason.startswith("yellow light")  # 3.3 now: still stops
    assert decide(rules, 11.0, junction(15.0, "green")).stop_line_s_m is None  # green again: go
    assert decide(rules, 11.0, junction(15.0, "yellow")).stop_line_s_m is None  # a new yellow, 4.0 needed: go
    assert decide(rules, 10.0, junction(14.0, "yellow")).stop_line_s_m is None  # that one is still judged go


def test_a_stop_sign_holds_the_ego_until_it_has_stood_at_the_line_then_gaps_decide():
    rules = JunctionRules(TacticsConfig())
    held_s = TacticsConfig().right_of_way.gap_held_s
    assert decide(rules, 8.0, junction(30.0, must_yield=True, stop_sign=True)).reason.startswith("stop sign")
    stood = decide(rules, 0.0, junction(3.0, must_yield=True, stop_sign=True), time_s=5.0)
    assert "checking the gap" in stood.reason  # it has stood: now the gap must stay open a moment
    go = decide(rules, 0.0, junction(3.0, must_yield=True, stop_sign=True), time_s=5.0 + held_s)
    assert go.stop_line_s_m is None
    waiting = decide(rules, 0.0, junction(2.0, must_yield=True, stop_sign=True, foe_arrival_s=3.0), time_s=9.0)
    assert "giving way (a vehicle with priority arrives in 3.0 s)" in waiting.reason


def test_giving_way_holds_the_ego_while_a_vehicle_with_priority_arrives_within_the_gap():
    rules = JunctionRules(TacticsConfig())
    gap_s, held_s = TacticsConfig().right_of_way.gap_s, TacticsConfig().right_of_way.gap_held_s
    assert decide(rules, 8.0, junction(20.0, must_yield=True, foe_arrival_s=gap_s - 1.0)).stop_line_s_m is not None
    assert decide(rules, 8.0, junction(20.0, must_yield=True, foe_arrival_s=gap_s + 1.0)).stop_line_s_m is None
    assert decide(rules, 8.0, junction(20.0, must_yield=True)).stop_line_s_m is None  # nobody coming
    # near the line a gap that just opened is watched for gap_held_s first (a car may appear from a short lane)
    assert decide(rules, 0.0, junction(2.0, must_yield=True, foe_arrival_s=1.0), time_s=10.0).stop_line_s_m
    assert "checking the gap" in decide(rules, 0.0, junction(2.0, must_yield=True), time_s=10.04).reason
    assert decide(rules, 0.0, junction(2.0, must_yield=True), time_s=10.04 + held_s).stop_line_s_m is None


def test_rules_left_out_do_not_act():
    rules = JunctionRules(TacticsConfig(rules=("queue_room",)))
    assert decide(rules, 12.0, junction(40.0, "red")).stop_line_s_m is None
    assert decide(rules, 8.0, junction(20.0, must_yield=True, foe_arrival_s=1.0)).stop_line_s_m is None


def test_slower_stretches_of_the_route_cap_the_speed_ahead_of_them():
    zones = ((150.0, 170.0, 6.0),)  # a turn at 6 m/s from 150 m
    rules = JunctionRules(TacticsConfig(), zones)
    decel = TacticsConfig().speed_zones.decel_mps2
    front_s = 100.0 + 0.5 * EGO_LENGTH_M
    assert rules.decide(observation(12.0), EGO_LENGTH_M).speed_cap_mps == pytest.approx(
        math.sqrt(36.0 + 2.0 * decel * (150.0 - front_s)))
    assert rules.decide(observation(6.0, road_s_m=155.0), EGO_LENGTH_M).speed_cap_mps == 6.0
    assert rules.decide(observation(6.0, road_s_m=200.0), EGO_LENGTH_M).speed_cap_mps is None
    limited = JunctionRules(TacticsConfig(), zones, speed_limit_mps=13.89)  # far ahead the zone allows more
    far = limited.decide(observation(12.0, road_s_m=0.0), EGO_LENGTH_M)
    assert far.speed_cap_mps is None and far.reason is None
    assert JunctionRules(TacticsConfig(rules=("traffic_lights",)), zones).decide(
        observation(12.0), EGO_LENGTH_M).speed_cap_mps is None


def test_the_plan_and_the_agents_situation_say_why_the_car_stops():
    layer = TacticsLayer(TacticsConfig(), TacticalRoad((0.0,), EGO_LENGTH_M, 2.0))
    plan = layer.plan(observation(12.0, junction(40.0, "red")), tracked_lane=0)
    assert plan.stop_line_s_m == pytest.approx(142.6) and plan.speed_cap_mps is not None
    assert layer.to_json()["junction"].startswith("red light at junction J")
    assert layer.situation().startswith("junction rules: red light")
    layer.plan(observation(12.0, junction(40.0, "green")), tracked_lane=0)
    assert "junction" not in layer.to_json() and layer.situation() is None


def inside(distance_m: float, inside_arrival_s: float | None, *, signal: str = "green", must_yield: bool = True,
           wait_in_m: float = 8.0, front_s_m: float = 102.6) -> JunctionAhead:
    """A left turn with a waiting point ``wait_in_m`` past the line; the ego's front ``-distance_m`` past it."""
    stop = front_s_m + distance_m
    return JunctionAhead("J", stop, stop + 24.0, distance_m, "left", signal, must_yield, False, None, stop + wait_in_m,
                         inside_arrival_s)


def test_a_turn_with_a_waiting_point_goes_in_and_waits_there_for_a_gap_in_the_oncoming_traffic():
    rules = JunctionRules(TacticsConfig())
    decide(rules, 0.0, inside(2.0, 1.0))  # oncoming traffic arriving: no reason to wait at the line, once the
    at_line = decide(rules, 0.0, inside(2.0, 1.0), time_s=1.5)  # (entry) gap has held: in, to the waiting point
    assert at_line.stop_line_s_m == pytest.approx(102.6 + 2.0 + 8.0) and at_line.speed_cap_mps > 4.0
    fast = decide(JunctionRules(TacticsConfig()), 9.3, inside(20.0, 2.0), time_s=5.0)
    assert fast.speed_cap_mps == pytest.approx((2.0 * 2.0 * 27.0) ** 0.5)  # it comes in able to stop there
    waiting = decide(rules, 3.0, inside(-3.0, 1.0))  # in the junction, 5 m before the waiting point
    assert waiting.stop_line_s_m == pytest.approx(102.6 - 3.0 + 8.0)
    assert waiting.reason.startswith("giving way inside the junction")
    assert waiting.speed_cap_mps == pytest.approx(4.0)  # braking at 2 m/s² for the point, 1 m before it
    checking = decide(rules, 0.0, inside(-6.5, 9.0), time_s=2.0)
    assert checking.reason.startswith("giving way inside the junction (checking the gap)")
    assert decide(rules, 0.0, inside(-6.5, 9.0), time_s=3.0).stop_line_s_m is None  # a gap held 1 s: it turns
    assert decide(rules, 0.0, inside(-6.5, None, signal="red", must_yield=False)).stop_line_s_m is None  # clearing
    assert decide(rules, 1.0, inside(-7.8, 1.0)).stop_line_s_m is not None  # crept up to 0.2 m before it: waits
    assert decide(rules, 5.0, inside(-9.0, 1.0)).stop_line_s_m is None  # past the waiting point: it clears
