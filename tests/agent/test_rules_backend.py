"""The rule-based backend: the paper's messages give the paper's calls, and the grammar generalises."""

from __future__ import annotations

import pytest

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.rules import DrivingState, RulesBackend, interpret, normalise
from agentic_mpc.agent.messages import Message

LIMIT_MPS = 25.0
TOOLS = {
    name: ToolSpec(name, "", {"type": "object", "properties": {"v_ref": {"type": "number", "minimum": 0.0,
                                                                          "maximum": LIMIT_MPS}}})
    for name in ("run_center_lane", "run_left_lane", "run_right_lane", "set_reference_speed")
}
TOOLS["set_preferred_steering_direction"] = ToolSpec(
    "set_preferred_steering_direction", "", {"type": "object", "properties": {"direction": {"enum": ["left", "right"]}}}
)
TOOLS["clear_preferred_steering_direction"] = ToolSpec("clear_preferred_steering_direction", "", {"type": "object"})

INITIAL = DrivingState("center", 15.0, None)
YIELDED = DrivingState("left", 0.0, None)


def calls(text: str, current: DrivingState = INITIAL, initial: DrivingState = INITIAL) -> list[tuple[str, dict]]:
    return RulesBackend().plan(text, initial, current, TOOLS).calls


# ---------------------------------------------------------------------------------------------- the paper
def test_paper_scenario_1_right():
    assert calls("Let's try to avoid obstacles from the right, shall we?") == [
        ("set_preferred_steering_direction", {"direction": "right"})
    ]


def test_paper_scenario_1_left():
    assert calls("Let's try to avoid obstacles from the left, shall we?") == [
        ("set_preferred_steering_direction", {"direction": "left"})
    ]


def test_paper_scenario_2_yield():
    assert calls("An ambulance is coming behind us. We'd better let them pass.") == [("run_left_lane", {"v_ref": 0})]


def test_paper_scenario_2_resume_restores_the_initial_lane_and_speed():
    assert calls("Thank you. The ambulance is gone.", current=YIELDED) == [("run_center_lane", {"v_ref": 15})]


def test_resume_restores_whatever_the_initial_specification_was():
    initial = DrivingState("right", 12.0, None)
    assert calls("Thanks, the ambulance has passed us.", current=YIELDED, initial=initial) == [
        ("run_right_lane", {"v_ref": 12})
    ]


# ---------------------------------------------------------------------------------------------- steering
@pytest.mark.parametrize(
    ("message", "side"),
    [
        ("Please go around obstacles on the right side.", "right"),
        ("Could you dodge to the left when something is in the way?", "left"),
        ("I'd prefer that we pass the obstacle on its left.", "left"),
        ("Swerve right if there's debris.", "right"),
        ("Pass it on the right-hand side, please", "right"),
        ("Evade to the LEFT.", "left"),
        ("When you avoid the cone, take the right.", "right"),
        ("Steer left around that rock", "left"),
        ("How about passing obstacles on the right?", "right"),
        ("if there's an obstacle, go right", "right"),
        ("Avoid the obstacle by veering left.", "left"),
        ("We should dodge obstacles rightward.", "right"),
        ("Could we swing left around the cone?", "left"),
        ("Right, pass on the left.", "left"),
        ("You're right, let's avoid obstacles on the left.", "left"),
        ("All right, bear right around the obstacle.", "right"),
    ],
)
def test_steering_paraphrases(message, side):
    assert calls(message) == [("set_preferred_steering_direction", {"direction": side})]


@pytest.mark.parametrize(
    ("message", "side"),
    [
        ("Don't pass on the left.", "right"),
        ("Please don't avoid obstacles from the right.", "left"),
        ("Never swerve right around obstacles.", "left"),
        ("Let's not go left around the obstacle.", "right"),
        ("I'd rather not pass obstacles on the right side", "left"),
        ("Avoid passing on the left.", "right"),
        ("Pass obstacles on the right rather than the left", "right"),
        ("Go around it on the left instead of the right.", "left"),
        ("Not on the left, on the right please, when you pass the obstacle", "right"),
        ("Keep the obstacle on our left.", "right"),
        ("Leave the obstacle to your right", "left"),
        ("The right side is blocked, go around the obstacle.", "left"),
        ("Don't hesitate to pass obstacles on the left.", "left"),
        ("Dodging on the left side isn't a good idea... wait, no: avoid it without going left.", "right"),
    ],
)
def test_steering_negations_and_inversions(message, side):
    assert calls(message) == [("set_preferred_steering_direction", {"direction": side})]


@pytest.mark.parametrize(
    "message",
    [
        "Either side is fine for obstacles.",
        "I don't care which side you pass obstacles on.",
        "Forget the steering preference.",
        "Drop that side preference please",
        "Whichever side, it's up to you.",
    ],
)
def test_clearing_the_preference(message):
    assert calls(message, current=DrivingState("center", 15.0, "left")) == [("clear_preferred_steering_direction", {})]


def test_both_sides_without_negation_is_ambiguous_and_makes_no_call():
    plan = RulesBackend().plan("Pass obstacles on the left or on the right", INITIAL, INITIAL, TOOLS)
    assert plan.calls == [] and any("both sides" in note for note in plan.notes)


# ---------------------------------------------------------------------------------------------- speeds
@pytest.mark.parametrize(
    ("message", "v_ref"),
    [
        ("Slow down to 36 km/h.", 10),
        ("slow down to 36 kph please", 10),
        ("Drive at 72 kilometres per hour", 20),
        ("Go 20 mph", 8.941),
        ("Let's do 10 miles an hour", 4.47),
        ("Set the speed to 12 m/s", 12),
        ("Cruise at 7.5 meters per second", 7.5),
        ("Take it down to thirty-six km/h", 10),
        ("Speed up to 54 km/h", 15),
        ("Slow down by 18 km/h", 10),
        ("Speed up by 5 m/s", 20),
        ("Don't go faster than 36 km/h", 10),
        ("Keep it under 45 mph", 15),
        ("Please drive slower than 36 km/h", 10),
        ("Never drive faster than 10 m/s", 10),
        ("At least 20 m/s please", 20),
        ("Stop the car.", 0),
        ("Please come to a full stop", 0),
        ("Halt!", 0),
        ("Slow down a bit", 11.25),
        ("We're in no hurry, please drive more slowly", 11.25),
        ("You're going too fast.", 11.25),
        ("Could you speed up a little?", 18.75),
    ],
)
def test_speeds_with_units_and_relative_changes(message, v_ref):
    assert calls(message) == [("set_reference_speed", {"v_ref": v_ref})]


def test_speed_above_the_limit_is_clamped_to_the_tool_maximum():
    plan = RulesBackend().plan("Go 200 km/h!", INITIAL, INITIAL, TOOLS)
    assert plan.calls == [("set_reference_speed", {"v_ref": 25})]
    assert any("limit" in note for note in plan.notes)


@pytest.mark.parametrize("message", ["Slow down to 36.", "go 50", "Drive at 12 please"])
def test_a_speed_without_unit_asks_for_one(message):
    plan = RulesBackend().plan(message, INITIAL, INITIAL, TOOLS)
    assert plan.calls == []
    assert any("unit" in note for note in plan.notes)


@pytest.mark.parametrize("message", ["Don't stop.", "Please don't slow down", "do not speed up", "don't drive 20 km/h"])
def test_negated_speed_changes_make_no_call(message):
    assert calls(message) == []


# ---------------------------------------------------------------------------------------------- lanes
@pytest.mark.parametrize(
    ("message", "expected"),
    [
        ("Move to the right lane.", ("run_right_lane", {"v_ref": 15})),
        ("Change lanes to the left, please", ("run_left_lane", {"v_ref": 15})),
        ("Switch to the middle lane at 20 m/s", ("run_center_lane", {"v_ref": 20})),
        ("Merge into the left lane and slow down to 36 km/h", ("run_left_lane", {"v_ref": 10})),
        ("Not the left lane, take the right lane", ("run_right_lane", {"v_ref": 15})),
        ("The left lane is closed, use the right lane", ("run_right_lane", {"v_ref": 15})),
    ],
)
def test_lane_changes(message, expected):
    assert calls(message) == [expected]


def test_back_to_our_lane_uses_the_initial_lane():
    current = DrivingState("left", 15.0, None)
    assert calls("Go back to our lane", current=current) == [("run_center_lane", {"v_ref": 15})]


def test_a_stopped_car_changing_lane_moves_at_the_initial_speed():
    assert calls("Move to the center lane", current=YIELDED) == [("run_center_lane", {"v_ref": 15})]


# ---------------------------------------------------------------------------------------------- emergency vehicles
@pytest.mark.parametrize(
    ("message", "expected"),
    [
        ("There's a fire truck behind us with its siren on.", ("run_left_lane", {"v_ref": 0})),
        ("I can hear a siren.", ("run_left_lane", {"v_ref": 0})),
        ("Ambulance!", ("run_left_lane", {"v_ref": 0})),
        ("We need to let the fire engine pass.", ("run_left_lane", {"v_ref": 0})),
        ("The ambulance behind us is doing 90 km/h, make way.", ("run_left_lane", {"v_ref": 0})),
        ("Police car approaching from behind!", ("run_left_lane", {"v_ref": 0})),
        ("Ambulance on our tail, make way", ("run_left_lane", {"v_ref": 0})),
        ("Emergency vehicle coming, pull over to the right", ("run_right_lane", {"v_ref": 0})),
        ("An ambulance needs to get through. Move left and slow to 10 km/h.", ("run_left_lane", {"v_ref": 2.778})),
        ("The ambulance is faster than us, let it pass.", ("run_left_lane", {"v_ref": 0})),
        ("Observation (t = 12.3 s): An emergency vehicle (ambulance 'amb0') is approaching from behind, 45 m back.",
         ("run_left_lane", {"v_ref": 0})),
    ],
)
def test_yielding_to_emergency_vehicles(message, expected):
    assert calls(message) == [expected]


@pytest.mark.parametrize(
    ("message", "expected"),
    [
        ("An ambulance is coming behind us. We'd better let them pass, but don't stop.", ("run_left_lane", {"v_ref": 4})),
        ("Ambulance behind us: move over without stopping.", ("run_left_lane", {"v_ref": 4})),
        ("Emergency vehicle coming, pull over to the right but keep rolling", ("run_right_lane", {"v_ref": 4})),
        ("A fire engine is coming, make way and keep moving.", ("run_left_lane", {"v_ref": 4})),
        ("An ambulance is behind us. Make way at 2 m/s, no need to stop.", ("run_left_lane", {"v_ref": 2})),
    ],
)
def test_yielding_without_stopping_keeps_a_crawl(message, expected):
    # A car stopped beside an emergency vehicle's path makes SUMO slow it to 20 km/h; moving over at a crawl
    # does not. A stated speed still wins.
    assert calls(message) == [expected]


def test_yielding_without_stopping_never_speeds_up_a_slower_car():
    slow = DrivingState("center", 2.5, None)
    assert calls("Ambulance behind us, let it pass but don't stop", current=slow) == [("run_left_lane", {"v_ref": 2.5})]


@pytest.mark.parametrize(
    "message",
    [
        "The fire engine went by, let's continue.",
        "OK, the police car has overtaken us.",
        "All clear, the ambulance is ahead of us now.",
        "The ambulance is no longer behind us.",
        "The ambulance left a minute ago and is now far away.",
        "False alarm, there's no ambulance.",
        "Observation (t = 31.0 s): The emergency vehicle (ambulance 'amb0') has passed us; it is now 12 m ahead.",
    ],
)
def test_resuming_after_emergency_vehicles(message):
    assert calls(message, current=YIELDED) == [("run_center_lane", {"v_ref": 15})]


def test_an_ambulance_that_has_not_passed_yet_keeps_us_waiting():
    assert calls("The ambulance hasn't passed yet.", current=YIELDED) == []


def test_an_oncoming_ambulance_needs_no_yield():
    assert calls("An ambulance is coming towards us in the opposite lane.") == []


def test_custom_yield_lane_for_right_hand_traffic():
    plan = RulesBackend(yield_lane="right").plan("An ambulance is behind us.", INITIAL, INITIAL, TOOLS)
    assert plan.calls == [("run_right_lane", {"v_ref": 0})]


# ---------------------------------------------------------------------------------------------- resume / restore
def test_resume_after_a_stop():
    stopped = DrivingState("center", 0.0, None)
    assert calls("OK, let's carry on.", current=stopped) == [("run_center_lane", {"v_ref": 15})]


def test_resume_when_nothing_changed_makes_no_call():
    assert calls("Keep going.") == []


def test_restore_everything_also_restores_the_steering_preference():
    assert calls("Reset to the original settings.", current=DrivingState("left", 8.0, "right")) == [
        ("clear_preferred_steering_direction", {}),
        ("run_center_lane", {"v_ref": 15}),
    ]


# ---------------------------------------------------------------------------------------------- no calls
@pytest.mark.parametrize(
    "message",
    [
        "Hello!",
        "Thank you.",
        "What a lovely day.",
        "Nice car, by the way",
        "How are you today?",
        "Which lane are we in?",
        "How fast are we going?",
        "Is the ambulance gone?",
        "Why did you slow down?",
        "I'm right behind you on this one.",
        "Right now I'm just enjoying the view.",
        "If an ambulance comes, let it pass.",
        "My sister drives an ambulance for a living.",
        "I left my phone at home",
        "Tell me a joke",
        "That's right.",
        "Turn right at the next intersection.",
        "Change lanes.",
    ],
)
def test_small_talk_questions_and_conditions_make_no_call(message):
    assert calls(message, current=INITIAL) == []


def test_combined_requests_give_several_calls():
    assert calls("Pass obstacles on the right and slow down to 36 km/h") == [
        ("set_preferred_steering_direction", {"direction": "right"}),
        ("set_reference_speed", {"v_ref": 10}),
    ]


def test_normalise_expands_contractions_and_number_words():
    assert normalise("Don't go twenty-five km/h, let's do ten mph") == "do not go 25 km/h, let us do 10 mph"


def test_interpretation_is_deterministic():
    message = "An ambulance is coming behind us. We'd better let them pass."
    assert interpret(message) == interpret(message)


# ---------------------------------------------------------------------------------------------- as a backend
def _system(initial_attached):
    return Message("system", "sys", data={"initial_specification": {"attached": initial_attached}}, tau=0)


def test_reply_reads_the_initial_spec_from_the_system_message_and_the_current_one_from_tool_results():
    initial = [{"kind": "path_tracking", "lane": "center", "v_ref_mps": 15.0}]
    after_yield = [{"kind": "path_tracking", "lane": "left", "v_ref_mps": 0.0}]
    history = [
        _system(initial),
        Message("user", "An ambulance is behind us", tau=1),
        Message("assistant", "", tau=2),
        Message("tool", "{}", name="run_left_lane", data={"attached": after_yield}, tau=3),
        Message("assistant", "Done", tau=4),
        Message("user", "Speed up a bit", tau=5),
    ]
    reply = RulesBackend().reply(history, list(TOOLS.values()))
    # Stopped (v_ref 0): "speed up" returns to the initial speed.
    assert [(c.name, c.arguments) for c in reply.tool_calls] == [("set_reference_speed", {"v_ref": 15})]


def test_reply_after_tool_results_has_no_call_and_reports_errors():
    history = [
        _system([]),
        Message("user", "go 10 m/s", tau=1),
        Message("assistant", "", tau=2),
        Message("tool", "Error: v_ref too high", name="set_reference_speed", is_error=True, tau=3),
    ]
    reply = RulesBackend().reply(history, list(TOOLS.values()))
    assert reply.tool_calls == () and "refused" in reply.text and "v_ref too high" in reply.text
