"""The system message a small language model can use (``prompt: compact``, the chat backends' default).

Against the full one (:func:`agentic_mpc.agent.prompt.system_prompt`, which the rules backend's transcripts
keep): the road in three lines, the start as the lane and speed to restore, only the tools offered on this
road (:mod:`agentic_mpc.agent.toolset`) as one line each with a ``unit`` for speeds, what yielding and resuming
call here, a few rules a small model got wrong, and short examples. It depends on nothing that changes while
the car drives, so the model's server reads it once and keeps it in its prompt cache; what changes (the
situation, the passages retrieved for a message) goes with each message (:func:`compact_context`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.messages import Message
from agentic_mpc.agent.toolset import UNIT_ARGUMENT, offered, short_description, signature
from agentic_mpc.mcp.protocol import ToolName, lane_of_tool

JSON_FORMAT = (
    'Answer with one JSON object: a call {"name": "<tool>", "arguments": {...}}, or, when nothing must change, '
    '{"reply": "<short answer>"}. One call per answer; a second change goes in your next answer.'
)
NATIVE_FORMAT = "Call tools with the function-calling format; when nothing must change, answer in one short sentence."


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def _start(initial: dict[str, Any] | None) -> tuple[str | None, float | None, str | None]:
    """(lane, speed in m/s, steering side) the car starts with, from ``mpc://specification/initial``."""
    lane = speed = side = None
    for primitive in (initial or {}).get("attached") or []:
        if not isinstance(primitive, dict):
            continue
        if primitive.get("kind") == "path_tracking":
            lane, speed = primitive.get("lane"), _number(primitive.get("v_ref_mps"))
        if primitive.get("kind") == "preferred_steering_direction":
            side = primitive.get("direction")
    return lane, speed, side


def _call(tool: str, arguments: dict[str, Any], tool_mode: str = "native") -> str:
    """A call as the model is to write it: JSON in ``json_schema`` mode (a small model copied ``f(x=1)`` into
    its reply there), ``f(x=1)`` otherwise."""
    arguments = {key: int(value) if isinstance(value, float) and value == int(value) else value
                 for key, value in arguments.items()}
    if tool_mode == "json_schema":
        return json.dumps({"name": str(tool), "arguments": arguments})
    shown = ", ".join(f"{key}={json.dumps(value) if isinstance(value, str) else f'{value:g}'}"
                      for key, value in arguments.items())
    return f"{tool}({shown})"


def _road_lines(road: dict[str, Any] | None) -> list[str]:
    if not isinstance(road, dict) or not isinstance(road.get("lanes"), list):
        return []
    lanes = []
    for lane in road["lanes"]:
        if isinstance(lane, dict) and isinstance(lane.get("name"), str):
            role = "edge lane" if lane["name"] == road.get("edge_lane") else ""
            lanes.append(f"{lane['name']}{f' ({role})' if role else ''}")
    facts = [f"{road.get('traffic', '')} traffic".strip(), f"lanes from the road edge: {', '.join(lanes)}"]
    limit = _number(road.get("speed_limit_mps"))
    road_type, jurisdiction = road.get("road_type"), road.get("jurisdiction")
    if limit is not None:
        what = "the tools accept at most" if road_type else "speed limit"
        facts.append(f"{what} {limit:g} m/s ({limit * 3.6:.0f} km/h)")
    lines = ["Road: " + "; ".join(facts) + "."]
    if jurisdiction:
        lines.append(f"Jurisdiction {jurisdiction}" + (f", a {road_type} with no speed signed: its limit is the "
                                                       "law's, given with the message; asked for more, set that "
                                                       "limit and say so" if road_type else "")
                     + "; follow its rules and cite them.")
    return lines


def compact_system_prompt(initial: dict[str, Any] | None, tools: Sequence[ToolSpec], extra: str = "",
                          road: dict[str, Any] | None = None, toolset: str = "auto",
                          tool_mode: str = "json_schema") -> str:
    """The compact system message (see the module docstring); ``tools`` are every listed tool."""
    shown = offered(tools, toolset)
    names = {t.name for t in shown}
    lane, speed, side = _start(initial)
    lines = [("You drive a car for its passenger by calling tools that change how the controller drives. Call a "
             "tool only when the passenger asks for a change now or an emergency vehicle needs way; for a "
             "question, small talk, a mention or a plan for later, reply briefly without a call."),
             *_road_lines(road)]
    if lane is not None and speed is not None:
        lines.append(f"Start (restore it for 'back to normal', 'reset', 'undo'): {lane} lane at {speed:g} m/s, "
                     f"{'preferred side ' + side if side else 'no preferred side'}.")
    lines.append("Tools:")
    lines += [f"- {signature(t)}: {short_description(t)}" for t in shown]
    if any(UNIT_ARGUMENT in (t.input_schema.get("properties") or {}) or "v_ref" in (t.input_schema.get("properties") or {})
           for t in shown):
        lines.append('unit: "m/s", "km/h" or "mph": write the number the passenger said and its unit; the tool '
                     "converts it and keeps to the limit.")
    rules = []
    yield_call, resume_call = (road or {}).get("yield_call"), (road or {}).get("resume_call")
    if isinstance(yield_call, dict) and yield_call.get("tool") in names:
        rules.append("An emergency vehicle (ambulance, fire truck, police car, siren) behind us, or 'make way', "
                     f"'pull over': {_call(yield_call['tool'], {**yield_call.get('arguments', {}), 'unit': 'm/s'}, tool_mode)}.")
    if isinstance(resume_call, dict) and resume_call.get("tool") in names:
        rules.append("It has passed, is gone, all clear: "
                     f"{_call(resume_call['tool'], {**resume_call.get('arguments', {}), 'unit': 'm/s'}, tool_mode)}. "
                     "Not passed yet: reply, no call.")
    rules.append("A question (what, how fast, which lane, why, is it allowed) gets a reply, never a call; "
                 "'could you ...?' asks for a change.")
    if ToolName.SET_PREFERRED_STEERING_DIRECTION in names:
        rules.append("Obstacle sides: 'not on the left' means right; 'keep it on our left' means pass it on "
                     "the right (and the other way round).")
    if ToolName.SET_REFERENCE_SPEED in names:
        rules.append("'A bit faster' or 'hurry': about 20 % above the speed now; 'slower', 'too fast': about "
                     "20 % below; 'stop': v_ref=0.")
    if any(lane_of_tool(n) for n in names):
        rules.append("A lane change keeps the speed now unless a new one is asked.")
    if any("__" in n for n in names):
        rules.append("Rules and facts retrieved for a message come with it, each with an [id]: use them and "
                     "name the id in your reply; search only for what they do not answer.")
    if rules:
        lines += ["Rules:", *[f"- {rule}" for rule in rules]]
    examples = [("Avoid obstacles from the right.", ToolName.SET_PREFERRED_STEERING_DIRECTION, {"direction": "right"}),
                ("Go 36 km/h.", ToolName.SET_REFERENCE_SPEED, {"v_ref": 36, "unit": "km/h"}),
                ("What a nice day!", None, {})]
    no_call = '{"reply": "Lovely weather for a drive."}' if tool_mode == "json_schema" else "a reply, no call"
    lines += ["Examples:", *[f'"{said}" -> {_call(tool, arguments, tool_mode) if tool else no_call}'
                             for said, tool, arguments in examples if tool is None or tool in names]]
    lines.append(JSON_FORMAT if tool_mode == "json_schema" else NATIVE_FORMAT)
    if extra:
        lines.append(extra)
    return "\n".join(lines)


_KEPT = ("- we drive", "- car ahead", "- emergency vehicle", "- tactic")


def _set_now(line: str) -> str:
    """The attached specification as the model's tools set it: ``- set now: left lane at 0 m/s, pass
    obstacles on the right`` (what the car is told, which a stopped or turning car is not yet doing)."""
    lane = re.search(r"path_tracking\(lane=(\w+), v_ref_mps=([\d.]+)", line)
    side = re.search(r"preferred_steering_direction\([^)]*direction=(left|right)", line)
    parts = [f"{lane.group(1)} lane at {lane.group(2)} m/s" if lane else "",
             f"pass obstacles on the {side.group(1)}" if side else "no preferred side"]
    following = re.search(r"following_distance\([^)]*gap_m=([\d.]+)", line)
    parts.append(f"{following.group(1)} m behind the car ahead" if following else "")
    return "- set now: " + ", ".join(part for part in parts if part)


def compact_context(context: str | None) -> str | None:
    """The situation in a few lines: our lane and speed, a car ahead, an emergency vehicle, what the tools have
    set (lane, speed, side); what is as at the start (no emergency vehicle, no car ahead) and the lanes the
    system message gives left out; what follows the situation (retrieved passages, memory) as it is."""
    if not context:
        return context
    situation, _, rest = context.partition("\n\n")
    if not situation.startswith("Current situation"):
        return context
    kept = []
    for line in situation.splitlines()[1:]:
        if line.startswith(_KEPT):
            kept.append(line)
        elif line.startswith("- attached:"):
            kept.append(_set_now(line))
    head = situation.splitlines()[0]
    parts = ([head + "\n" + "\n".join(kept)] if kept else []) + ([rest] if rest.strip() else [])
    return "\n\n".join(parts) or None


MAX_EARLIER = 4
"""Earlier steps said in the context of the step being answered, at most."""


def earlier_lines(messages: Sequence[Message]) -> str | None:
    """What the passenger said before and the calls made for it, one line each (the last
    :data:`MAX_EARLIER` steps), instead of those steps' messages: a small model that sees its earlier replies
    replies again ("It is!" to "the ambulance is gone")."""
    steps: list[list[str]] = []
    for message in messages:
        if message.role == "user" and message.source != "agent":
            who = "observed" if message.source == "observation" else "passenger"
            steps.append([f"- {who}: {message.content.strip()[:200]}"])
        elif message.role == "assistant" and steps:
            for call in message.tool_calls:
                if call.error is None and call.arguments is not None:
                    steps[-1].append(f"  you called {_call(call.name, call.arguments)}")
    if not steps:
        return None
    shown = [line for step in steps[-MAX_EARLIER:] for line in step]
    return "Earlier in this drive:\n" + "\n".join(shown)


def compact_history(history: Sequence[Message]) -> list[Message]:
    """The request's messages for the compact prompt: the system message, then the step being answered
    (from its message on), whose context says the situation in a few lines and the earlier steps in one line
    each (:func:`earlier_lines`)."""
    messages = list(history)
    head = messages[:1] if messages and messages[0].role == "system" else []
    starts = [i for i in range(len(head), len(messages))
              if messages[i].role == "user" and messages[i].source != "agent"]
    if not starts:
        return messages
    current = messages[starts[-1]:]
    earlier = earlier_lines(messages[len(head):starts[-1]])
    first = current[0]
    context = "\n\n".join(part for part in (earlier, compact_context(first.context)) if part)
    return head + [replace(first, context=context or None)] + [
        replace(m, context=compact_context(m.context)) if m.role == "user" and m.context else m for m in current[1:]]
