"""After a model's calls: did they do everything the message asked for?

Two costs of the answer that follows tool results, measured with Qwen2.5-Coder-1.5B on one CPU thread
(docs/llm-backends.md): it takes 4-5 s of a 10-11 s step only to confirm what the results already say, and
with two requests in one message ("avoid obstacles from the left and slow down to 10 m/s") the model made one
call and then replied, in all 8 such cases of the eval suite. So the chat backends (``confirmation:
template``, with the compact prompt) read the message for the *kinds* of change it asks for, with the rules'
lexicon, and compare them with the kinds the step's successful calls made:

- everything asked is done: the step's reply is written from the results (:func:`template_reply`), citing the
  passages retrieved for the message as a model's reply must (the knowledge the call was made with), and no
  answer is asked of the model;
- a kind is left (:func:`left_undone`): the model is asked again, told which part of the message is left.

Kinds: ``side`` (a side for obstacles), ``speed`` (a speed with its unit, slower, faster), ``lane`` (a named
lane, back to our lane), ``gap`` (a following distance). A message with none of them (an ambulance behind
us, "the ambulance is gone") is done by any successful call. Only calls that change the car count: after a
knowledge search, or a call that failed, the model answers as before.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Literal

from agentic_mpc.agent.backends.rules_lexicon import (
    _BACK_TO_LANE,
    _FAST,
    _LANE_LABEL,
    _LANE_MOVE,
    _SLOW,
    _SPEED,
    _STEERING_CONTEXT,
)
from agentic_mpc.agent.backends.rules_parsing import clauses, normalise, side_mentions
from agentic_mpc.agent.messages import Message
from agentic_mpc.mcp.protocol import ToolName, lane_of_tool

Kind = Literal["side", "speed", "lane", "gap"]

_GAP = re.compile(r"\b(?:follow\w*|distance|gap|tailgat\w*|\d+ ?(?:m|metres|meters) behind)\b")
_JOINED = re.compile(r"^(?:and|also|plus)\s+|\s+(?:and|also|plus)\s+")
_VEHICLE = re.compile(r"\b(?:car|truck|lorry|vehicle|bus|van|him|her)\b")
_SAID_AS = {"side": "the side to pass obstacles on", "speed": "the speed", "lane": "the lane",
            "gap": "the following distance"}

_MAKES: dict[str, frozenset[Kind]] = {
    ToolName.SET_PREFERRED_STEERING_DIRECTION: frozenset({"side"}),
    ToolName.CLEAR_PREFERRED_STEERING_DIRECTION: frozenset({"side"}),
    ToolName.SET_REFERENCE_SPEED: frozenset({"speed"}),
    ToolName.CHANGE_REFERENCE_SPEED: frozenset({"speed"}),
    ToolName.CHANGE_LANE: frozenset({"lane"}),
    ToolName.KEEP_LANE: frozenset({"lane", "speed"}),
    ToolName.OVERTAKE: frozenset({"lane", "side"}),
    ToolName.PULL_OVER: frozenset({"lane", "speed"}),
    ToolName.SET_FOLLOWING_DISTANCE: frozenset({"gap"}),
    ToolName.CHANGE_FOLLOWING_DISTANCE: frozenset({"gap"}),
    ToolName.CLEAR_FOLLOWING_DISTANCE: frozenset({"gap"}),
    ToolName.TURN_AT_NEXT_JUNCTION: frozenset({"lane", "side"}),
    ToolName.DRIVE_TO: frozenset({"lane", "side"}),
}
"""What each tool of the car changes (a lane tool: the lane and the speed, its ``v_ref``)."""


def asked_kinds(message: str) -> dict[Kind, str]:
    """The kinds of change ``message`` asks for, each with the part of the message that asks for it."""
    found: dict[Kind, str] = {}
    parts = [p for clause in clauses(normalise(message)) for p in _JOINED.split(clause) if p.strip()]
    for part in parts:
        if _LANE_MOVE.search(part) and (_LANE_LABEL.search(part) or _BACK_TO_LANE.search(part)):
            found.setdefault("lane", part)
        elif _STEERING_CONTEXT.search(part) and side_mentions(part) and not _VEHICLE.search(part):
            found.setdefault("side", part)  # a side for obstacles; passing a car on a side is an overtake
        if _SPEED.search(part) or _SLOW.search(part) or _FAST.search(part):
            found.setdefault("speed", part)
        if _GAP.search(part):
            found.setdefault("gap", part)
    return found


def _made(name: str) -> frozenset[Kind]:
    if lane_of_tool(name) is not None:
        return frozenset({"lane", "speed"})
    return _MAKES.get(name, frozenset())


def _step(history: Sequence[Message]) -> Sequence[Message]:
    """The step being answered: its message and everything after it (empty if there is none)."""
    for index in range(len(history) - 1, -1, -1):
        if history[index].role == "user" and history[index].source != "agent":
            return history[index:]
    return ()


def _last_round(history: Sequence[Message]) -> list[Message]:
    """The results of the answer just made (the tool messages at the end of the history)."""
    results: list[Message] = []
    for message in reversed(history):
        if message.role != "tool":
            break
        results.append(message)
    return results[::-1]


def left_undone(history: Sequence[Message]) -> dict[Kind, str] | None:
    """After tool results: the kinds the step's message asked for that no successful call of the step made;
    None when the last answer's calls are not all successful calls of the car (then the model answers)."""
    step, last = _step(history), _last_round(history)
    if not step or not last or any(m.is_error or not _made(m.name or "") for m in last):
        return None
    made: set[Kind] = set().union(*(_made(m.name or "") for m in step if m.role == "tool" and not m.is_error))
    return {kind: part for kind, part in asked_kinds(step[0].content).items() if kind not in made}


def follow_up_note(undone: dict[Kind, str]) -> str:
    """What the model is told when part of the message is left."""
    parts = "; ".join(f"{_SAID_AS[kind]} (\"{part}\")" for kind, part in undone.items())
    return f"The message also asks for {parts}: make that call now."


def template_reply(history: Sequence[Message], cites: Sequence[str] = ()) -> str:
    """The step's reply written from its successful calls, the notes the tool layer added to them (a speed set
    to the limit, a unit converted) and the documents retrieved for the message (``cites``), as a model's
    reply names them ("... [jp-traffic-rules]")."""
    step = _step(history)
    applied = {m.tool_call_id for m in step if m.role == "tool" and not m.is_error}
    done = [f"{c.name}({', '.join(f'{k}={v}' for k, v in (c.arguments or {}).items())})"
            for m in step if m.role == "assistant" for c in m.tool_calls if c.id in applied]
    notes = [m.content.strip() for m in step if m.role == "assistant" and m.tool_calls and m.content.strip()]
    return " ".join([f"Done: {'; '.join(done)}.", *notes, *(f"[{cite}]" for cite in cites)])
