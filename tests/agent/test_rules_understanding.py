"""The rules answer a message only when they understood every part of it that asks for something; otherwise
they say what they did not understand and make no call (with ``rules_first``, the model answers)."""

from __future__ import annotations

import pytest

from agentic_mpc.agent import Agent
from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.backends.rules import DrivingState, RulesBackend
from agentic_mpc.agent.backends.rules_first import RulesFirst
from agentic_mpc.agent.backends.rules_understanding import not_english, not_understood
from agentic_mpc.agent.settings import OpenAISettings
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call

SPEED = {"type": "object", "properties": {"v_ref": {"type": "number", "minimum": 0.0, "maximum": 31.29}}}
TOOLS = {name: ToolSpec(name, "", SPEED) for name in ("run_center_lane", "run_left_lane", "run_right_lane",
                                                       "set_reference_speed")}
for name in ("set_following_distance", "change_following_distance", "overtake", "pull_over",
             "set_preferred_steering_direction", "clear_preferred_steering_direction"):
    TOOLS[name] = ToolSpec(name, "", {"type": "object"})
START = DrivingState("center", 20.0, None)


def plan(message: str):
    return RulesBackend().plan(message, START, START, TOOLS)


@pytest.mark.parametrize("message, call", [
    ("Go 4 m/s slower than now.", ("set_reference_speed", {"v_ref": 16})),
    ("Add 3 meters per second to our speed.", ("set_reference_speed", {"v_ref": 23})),
    ("Take 6 meters per second off our speed.", ("set_reference_speed", {"v_ref": 14})),
    ("Stay 15 meters behind the car ahead.", ("set_following_distance", {"gap": 15.0})),
    ("Leave 70 metres between us and the car in front.", ("set_following_distance", {"gap": 70.0})),
    ("Drop back to a 65 m gap.", ("set_following_distance", {"gap": 65.0})),
    ("Give the car ahead 10 more metres.", ("change_following_distance", {"change": 10.0})),
    ("Move up 15 meters on the lead vehicle.", ("change_following_distance", {"change": -15.0})),
    ("Decrease gap by 13 meters.", ("change_following_distance", {"change": -13.0})),  # LaMPilot's own
])
def test_relative_speeds_and_gaps_said_many_ways(message, call):
    assert plan(message).calls == [call] and not plan(message).not_understood


@pytest.mark.parametrize("message, part", [
    ("Speed up 7 m/s from here.", "speed up 7 m/s from here"),  # a target or a change? not a guess
    ("Lower the speed 6 m/s.", "lower the speed 6 m/s"),
    ("Slow by 4 m/s.", "slow by 4 m/s"),  # a change, but which way?
    ("Hang back so there are 70 m to the vehicle in front.", "hang back so there are 70 m to the vehicle in front"),
    ("Turn left at the next junction.", "turn left at the next junction"),
    ("Avoid obstacles on the left, then flash the headlights 2 times.", "flash the headlights 2 times"),
])
def test_a_part_not_understood_makes_no_call_and_is_named(message, part):
    result = plan(message)
    assert result.calls == [] and part in result.not_understood
    assert f'I did not understand "{part}"' in " ".join(result.notes)


def test_a_change_that_says_neither_more_nor_less_is_asked_back():
    result = plan("Trail the car ahead by 25 meters.")
    assert result.calls == [] and "Should the gap grow or shrink?" in result.notes[0]


@pytest.mark.parametrize("message", ["Bitte weiche Hindernissen rechts aus.", "右側から障害物を避けてください。",
                                     "Esquiva los obstáculos por la izquierda."])
def test_a_language_the_rules_do_not_read_is_said_so(message):
    result = plan(message)
    assert not_english(message) and result.calls == [] and "I only read English" in result.notes[0]


@pytest.mark.parametrize("message", ["Hold 14 meters per second.", "Drop 8 meters per second.", "What a nice day!",
                                     "Thank you. The ambulance is gone.", "Which lane are we in?"])
def test_short_english_is_english_and_small_talk_asks_for_nothing(message):
    assert not not_english(message)
    if "?" in message or "nice day" in message:
        assert not_understood(message, TOOLS, answered_as_such="?" in message) == []


def test_rules_first_hands_a_message_not_understood_to_the_model_and_keeps_what_they_read(server):
    """Through a real MCP server: the rules answer what they read; what they did not understand goes to the model
    (here a scripted OpenAI-compatible server), whose call is applied."""
    script = [calls(tool_call("set_reference_speed", {"v_ref": 12}))]  # its reply: written from the result
    with ScriptedLLM(script) as llm:
        model = OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="m", api_key_env=None))
        backend = RulesFirst(RulesBackend(yield_lane="right"), model)
        with Agent(backend, server) as agent:
            read = agent.deliver("Avoid obstacles from the right.").result(30)
            handed = agent.deliver("Lower the speed 3 m/s.").result(30)
    assert read.applied_calls == [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "right"}}]
    assert handed.applied_calls == [{"tool": "set_reference_speed", "arguments": {"v_ref": 12}}]
    assert backend.routed_to_model == 1 and len(llm.requests) == 1
    assert handed.text.startswith("Done: set_reference_speed(v_ref=12")


def test_what_cannot_be_met_is_said_back_to_the_passenger_with_why(server):
    """Through a real MCP server and the agent's loop: a speed above the limit is capped and the last reply says so;
    a distance with no car to follow is refused by the tool and its reason reaches the passenger."""
    with Agent(RulesBackend(yield_lane="right"), server) as agent:
        capped = agent.deliver("Go 50 m/s.").result(30)
        refused = agent.deliver("Keep a 30 m gap to the car ahead.").result(30)
    limit = capped.applied_calls[0]["arguments"]["v_ref"]
    assert limit < 50 and f"50 m/s is above the road speed limit; using the limit, {limit:g} m/s." in capped.text
    assert not refused.applied_calls and "refused" in refused.text and "no car ahead" in refused.text
