"""The rules backend's manoeuvres: a following distance, overtaking, pulling over onto the emergency lane,
relative speeds (our phrasings; LaMPilot's own are the benchmark's to measure)."""

from __future__ import annotations

import pytest

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.rules import DrivingState, RulesBackend
from tests.agent.test_rules_backend import TOOLS

MANOEUVRES = {**TOOLS, **{name: ToolSpec(name, "", {"type": "object"}) for name in (
    "set_following_distance", "change_following_distance", "overtake", "pull_over")}}
STATE = DrivingState("center", 20.0, None)


def calls(text: str, tools=MANOEUVRES) -> list[tuple[str, dict]]:
    return RulesBackend().plan(text, STATE, STATE, tools).calls


@pytest.mark.parametrize(("message", "expected"), [
    ("Keep a 30 m gap to the car ahead.", ("set_following_distance", {"gap": 30.0})),
    ("Hold the following distance at 45 metres, please.", ("set_following_distance", {"gap": 45.0})),
    ("Could you open up the gap by 10 m?", ("change_following_distance", {"change": 10.0})),
    ("Shorten the following distance by 5 meters.", ("change_following_distance", {"change": -5.0})),
    ("Make the gap 8 metres longer.", ("change_following_distance", {"change": 8.0})),
    ("Tighten the gap by 100 feet.", ("change_following_distance", {"change": -30.48})),
])
def test_following_distances(message, expected):
    assert calls(message) == [expected]


@pytest.mark.parametrize(("message", "expected"), [
    ("Pass the slow truck ahead on the left.", ("overtake", {"side": "left", "afterwards": "keep"})),
    ("Overtake the vehicle in front on the right and then come back.",
     ("overtake", {"side": "right", "afterwards": "return"})),
    ("Get ahead of the car in front using the left lane.", ("overtake", {"side": "left", "afterwards": "keep"})),
])
def test_overtakes(message, expected):
    assert calls(message) == [expected]


def test_an_overtake_without_a_side_asks_and_obstacles_stay_a_steering_preference():
    backend = RulesBackend()
    plan = backend.plan("Overtake the car ahead.", STATE, STATE, MANOEUVRES)
    assert plan.calls == [] and "left or right" in plan.notes[0]
    assert calls("Please go around obstacles on the left.") == [
        ("set_preferred_steering_direction", {"direction": "left"})]


def test_pull_over_onto_the_shoulder_only_where_the_tool_is_offered():
    assert calls("Pull onto the hard shoulder and stop, please.") == [("pull_over", {})]
    # no emergency lane on this road (no pull_over tool): the general grammar's "pull over" stops in lane
    assert calls("Pull onto the hard shoulder and stop, please.", TOOLS) == [("set_reference_speed", {"v_ref": 0})]


@pytest.mark.parametrize(("message", "v_ref"), [
    ("Decrease the speed by 4 m/s.", 16), ("Lessen the cruise speed by 2 m/s.", 18),
    ("Boost the speed by 3 m/s.", 23), ("Increase current speed by 10 m/s.", 25),  # capped at the limit, 25
])
def test_relative_speeds(message, v_ref):
    assert calls(message) == [("set_reference_speed", {"v_ref": v_ref})]


def test_a_following_distance_with_no_length_asks_for_one():
    plan = RulesBackend().plan("Increase the following distance.", STATE, STATE, MANOEUVRES)
    assert plan.calls == [] and "metres" in plan.notes[0]


ROUTE_TOOLS = {**MANOEUVRES, "turn_at_next_junction": ToolSpec("turn_at_next_junction", "", {"type": "object"})}


@pytest.mark.parametrize(("message", "direction"), [
    ("Turn left at the next junction.", "left"),
    ("When we reach the intersection, take a right.", "right"),  # a condition the turn tool itself waits for
    ("Make a right-turn at the lights.", "right"),
    ("At the crossroads please carry on straight.", "straight"),
    ("Go straight through the junction.", "straight"),
    ("Head to the left at the corner.", "left"),
])
def test_turns_at_the_next_junction_where_the_road_has_junctions(message, direction):
    assert calls(message, ROUTE_TOOLS) == [("turn_at_next_junction", {"direction": direction})]


def test_a_turn_is_not_read_where_the_road_has_no_junctions_nor_without_a_way():
    assert calls("Turn left at the next junction.") == []  # a motorway: no turn tool offered
    plan = RulesBackend().plan("At the junction, left or right?", STATE, STATE, ROUTE_TOOLS)
    assert plan.calls == []  # a question
    asked = RulesBackend().plan("At the junction go left or maybe right", STATE, STATE, ROUTE_TOOLS)
    assert asked.calls == [] and "Which way at the junction" in " ".join(asked.notes)
    assert calls("Keep to the left lane.", ROUTE_TOOLS) != [("turn_at_next_junction", {"direction": "left"})]
