"""The scoring rules on constructed answers (a StepReport's ``tool_calls``, as the agent records them)."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_mpc.agent_eval.expectations import CallSpec, Constraint, Turn
from agentic_mpc.agent_eval.scoring import judge, sort_attempts

TOOLS = ("run_left_lane", "run_center_lane", "run_right_lane", "set_reference_speed",
         "set_preferred_steering_direction", "clear_preferred_steering_direction")


def ok(tool: str, **arguments: Any) -> dict[str, Any]:
    return {"tool": tool, "arguments": arguments, "ok": True, "result": {}}


def refused(tool: str, arguments: dict[str, Any] | None, error: str = "refused") -> dict[str, Any]:
    return {"tool": tool, "arguments": arguments, "ok": False, "error": error}


STEER_LEFT = CallSpec(("set_preferred_steering_direction",), (("direction", Constraint("exact", "left")),))
SPEED_10 = CallSpec(("set_reference_speed", "run_center_lane"), (("v_ref", Constraint("approx", None, 9.7, 10.3)),))
FASTER = CallSpec(("set_reference_speed",), (("v_ref", Constraint("relative", None, 1.05, 1.5)),))


def verdict(turn: Turn, calls: list[dict[str, Any]], v_now: float | None = 15.0) -> bool:
    return judge(turn, sort_attempts(calls, TOOLS), v_now).right


def test_two_expected_calls_match_in_any_order_and_either_listed_tool():
    turn = Turn("left and 10 m/s", (STEER_LEFT, SPEED_10))
    assert verdict(turn, [ok("set_preferred_steering_direction", direction="left"), ok("set_reference_speed", v_ref=10)])
    assert verdict(turn, [ok("run_center_lane", v_ref=10.2), ok("set_preferred_steering_direction", direction="left")])


def test_a_missing_an_extra_or_an_out_of_tolerance_call_is_wrong():
    turn = Turn("left and 10 m/s", (STEER_LEFT, SPEED_10))
    assert not verdict(turn, [ok("set_preferred_steering_direction", direction="left")])
    assert not verdict(turn, [ok("set_preferred_steering_direction", direction="left"), ok("set_reference_speed", v_ref=10),
                              ok("run_left_lane", v_ref=10)])
    assert not verdict(turn, [ok("set_preferred_steering_direction", direction="left"), ok("set_reference_speed", v_ref=11)])
    assert not verdict(turn, [ok("set_preferred_steering_direction", direction="right"), ok("set_reference_speed", v_ref=10)])
    # the same spec cannot be used twice: two speed calls do not stand for a speed and a side
    assert not verdict(turn, [ok("set_reference_speed", v_ref=10), ok("run_center_lane", v_ref=10)])


def test_an_exact_repeat_counts_once_but_a_different_repeat_is_an_extra_call():
    turn = Turn("left", (STEER_LEFT,))
    attempts = sort_attempts([ok("set_preferred_steering_direction", direction="left")] * 3, TOOLS)
    assert attempts.repeats == 2 and judge(turn, attempts, 15.0).right
    assert not verdict(turn, [ok("set_preferred_steering_direction", direction="left"),
                              ok("set_preferred_steering_direction", direction="right")])


def test_a_vague_speed_is_judged_relative_to_the_speed_when_the_turn_starts():
    turn = Turn("a bit faster", (FASTER,))
    assert verdict(turn, [ok("set_reference_speed", v_ref=18)], v_now=15.0)
    assert not verdict(turn, [ok("set_reference_speed", v_ref=18)], v_now=10.0)  # 1.8x: more than a bit
    assert not verdict(turn, [ok("set_reference_speed", v_ref=15)], v_now=15.0)  # no change
    assert not verdict(turn, [ok("set_reference_speed", v_ref=18)], v_now=None)  # nothing to be relative to


def test_a_turn_that_needs_no_call_is_wrong_if_any_call_was_tried_even_a_refused_one():
    turn = Turn("What a nice day!", ())
    assert verdict(turn, [])
    assert not verdict(turn, [ok("clear_preferred_steering_direction")])
    assert not verdict(turn, [refused("set_reference_speed", {"v_ref": 99})])
    assert not verdict(turn, [refused("unparsed_tool_call", None, "not JSON")])


def test_refused_calls_are_sorted_into_unparsed_and_invalid_and_do_not_count_as_made():
    attempts = sort_attempts([
        refused("unparsed_tool_call", None, "the answer is not JSON"),
        refused("fly_to_the_moon", {}, "unknown tool"),
        refused("set_reference_speed", None, "arguments are not an object"),
        refused("set_reference_speed", {"v_ref": 36}, "36 is greater than the maximum of 25"),
        ok("set_reference_speed", v_ref=10),
    ], TOOLS)
    assert len(attempts.unparsed) == 3 and len(attempts.invalid) == 1
    assert "maximum" in attempts.invalid[0]
    assert attempts.accepted == ({"tool": "set_reference_speed", "arguments": {"v_ref": 10}},)
    assert judge(Turn("36 km/h", (SPEED_10,)), attempts, 15.0).right  # corrected after the refusal


def test_alternatives_and_backend_failures():
    turn = Turn("the ambulance is gone", (), alternatives=((CallSpec(("run_center_lane",)),),))
    assert verdict(turn, [])
    assert verdict(turn, [ok("run_center_lane", v_ref=15)])
    assert not verdict(turn, [ok("run_left_lane", v_ref=15)])
    failed = judge(Turn("left", (STEER_LEFT,)), sort_attempts([], TOOLS), 15.0, backend_failed=True)
    assert not failed.right and "no answer" in failed.detail


@pytest.mark.parametrize("constraint, good, bad", [
    (Constraint("exact", 15), [15, 15.0, 15.005], [15.1, "15", True]),
    (Constraint("exact", "left"), ["left"], ["Left", "right", None]),
    (Constraint("range", None, 0.0, 1.0), [0, 0.5, 1.0], [-0.1, 1.2, "0", float("nan")]),
    (Constraint("one_of", ("left", "right")), ["left", "right"], ["center"]),
    (Constraint("any"), [1, "x", None], []),
])
def test_argument_constraints(constraint, good, bad):
    assert all(constraint.matches(value, 15.0) for value in good)
    assert not any(constraint.matches(value, 15.0) for value in bad)
