"""The rules backend's use of memory: one hook, :func:`apply_memory`, over the plan it made for a message.

The agent puts what is remembered in the user message's ``data["memory"]``
(:mod:`agentic_mpc.agent.memory_recall`); without it the hook changes nothing. With it, in this order:

1. **a correction now** ("no, the other side" after a call): the previous step's calls with their side changed
   (to the side named, "not that lane, the right one", else the other one) replace the plan;
2. **an earlier correction** of a similar message (TF-IDF similarity >= :data:`CORRECTION_SIMILARITY`) whose
   wrong calls are the plan's: its right calls replace them (a plan without a call takes them at
   >= :data:`CORRECTION_SIMILARITY_WITHOUT_CALL`);
3. **standing preferences**, only where the message leaves it open: ``preferred_side`` for a message about
   evading something that names no side (a steering call is added) and for overtaking the car ahead without a
   side; ``yield_side`` for making way for an emergency vehicle without a side (its lane call moves there,
   unless a traffic rule looked up decided the lane: the rule wins and the note says so); ``max_speed_mps``
   caps a speed the message did not name (a speed it names wins, and the note says it is above the
   preference). ``preferred_lane`` is for a language model's eyes only.

Every change adds a note saying so (the reply and the transcript show it). The hook is idempotent.

Wiring: the rules backend calls it after planning a user message::

    plan = apply_memory(plan, message, tools)   # in RulesBackend.reply, after each self.plan(...)

and ``RulesFirst.complete`` after its ``self.rules.plan(...)``, so that a correction counts as understood.
This module imports nothing of ``rules.py``, so that ``rules.py`` can import it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import Any

from agentic_mpc.agent.backends.rules_parsing import interpret, normalise
from agentic_mpc.agent.messages import Message
from agentic_mpc.mcp.protocol import DIRECTION_ARGUMENT, SPEED_ARGUMENT, ToolName, lane_of_tool, lane_tool_name

CORRECTION_SIMILARITY = 0.5
CORRECTION_SIMILARITY_WITHOUT_CALL = 0.8
NOT_UNDERSTOOD = "(I am a rule-based stand-in"
"""How the rules' reply begins when they recognised nothing (and "I did not understand ..." when a part was not).
"""

_EVADE = re.compile(
    r"\b(?:obstacles?|obstructions?|objects?|debris|rocks?|cones?|barriers?|blockage|pothole|roadworks|"
    r"avoid\w*|evad\w*|around|dodg\w*|swerv\w*|steer\w*|bypass\w*|skirt\w*|detour)\b")
_OVERTAKE = re.compile(r"\b(?:overtake|overtaking|pass|go past|get past|drive past|get ahead of|go around)\b")
_CAR_AHEAD = re.compile(r"\b(?:car|vehicle|truck|lorry|bus|driver|one)s?\s+(?:in front|ahead)\b|"
                        r"\b(?:lead|leading|front)\s+(?:car|vehicle)\b")
_RETURN = re.compile(r"\b(?:come back|return|go back|merge back|get back)\b")
_SPEED_TOOLS = (ToolName.SET_REFERENCE_SPEED,)


def _other(side: Any) -> str | None:
    return {"left": "right", "right": "left"}.get(side)


def corrected_calls(calls: list[dict[str, Any]], side: str | None) -> list[dict[str, Any]] | None:
    """The previous ``calls`` with their side changed (to ``side``, else to the other one); None if no call
    has a side to change."""
    out, changed = [], False
    for call in calls:
        name, arguments = str(call["tool"]), dict(call.get("arguments") or {})
        lane = lane_of_tool(name)
        if name == ToolName.SET_PREFERRED_STEERING_DIRECTION and (new := side or _other(arguments.get(DIRECTION_ARGUMENT))):
            arguments[DIRECTION_ARGUMENT], changed = new, True
        elif name == ToolName.OVERTAKE and (new := side or _other(arguments.get("side"))):
            arguments["side"], changed = new, True
        elif lane is not None and (new := side or _other(lane)):
            name, changed = lane_tool_name(new), True
        out.append({"tool": name, "arguments": arguments})
    return out if changed else None


def _note(plan: Any, text: str) -> None:
    """Say what memory changed; what the rules could not settle alone (no side named) is settled now."""
    plan.notes[:] = [n for n in plan.notes if not n.startswith(NOT_UNDERSTOOD) and "which side should I" not in n
                     and not n.startswith("I did not understand")]
    if getattr(plan, "not_understood", None):
        plan.not_understood = []
    if text not in plan.notes:
        plan.notes.append(text)


def _same(a: Sequence[tuple[str, dict[str, Any]]], b: Sequence[tuple[str, dict[str, Any]]]) -> bool:
    def key(call: tuple[str, dict[str, Any]]) -> tuple[str, tuple[tuple[str, Any], ...]]:
        return str(call[0]), tuple(sorted((k, round(v, 3) if isinstance(v, float) else v) for k, v in call[1].items()))
    return sorted(map(key, a)) == sorted(map(key, b))


def _calls(calls: Iterable[dict[str, Any]]) -> list[tuple[str, dict[str, Any]]]:
    return [(str(c["tool"]), dict(c.get("arguments") or {})) for c in calls]


def apply_memory(plan: Any, message: Message | None, tools: Iterable[str] | None = None) -> Any:
    """``plan`` (``.calls``: (tool, arguments) pairs, ``.notes``) changed by what ``message.data["memory"]``
    holds (see the module docstring); ``tools``: the tool names offered (None: all)."""
    memory = (message.data or {}).get("memory") if message is not None else None
    if not memory:
        return plan
    offered = None if tools is None else set(tools)
    text = message.content
    correcting = memory.get("correcting")
    if correcting and (fixed := corrected_calls(correcting["calls"], correcting.get("side"))) is not None:
        plan.calls[:] = _calls(fixed)
        _note(plan, f"Correcting my answer to \"{correcting['message']}\"; I will remember it.")
        return plan
    for entry in memory.get("similar") or []:
        if entry.get("kind") != "correction":
            continue
        wrong, right = _calls(entry.get("wrong") or []), _calls(entry.get("right") or [])
        if _same(plan.calls, right):
            break
        if (plan.calls and _same(plan.calls, wrong) and entry["similarity"] >= CORRECTION_SIMILARITY) or (
                not plan.calls and entry["similarity"] >= CORRECTION_SIMILARITY_WITHOUT_CALL):
            plan.calls[:] = right
            _note(plan, f"As you corrected me before (\"{entry['corrects']}\", memory entry {entry['id']}).")
            return plan
    _preferences(plan, text, {k: v["value"] for k, v in (memory.get("preferences") or {}).items()}, offered)
    return plan


def _preferences(plan: Any, text: str, preferences: dict[str, Any], offered: set[str] | None) -> None:
    meaning = interpret(text)
    s = normalise(text)
    names = [str(name) for name, _ in plan.calls]
    side = preferences.get("preferred_side")
    no_side_named = meaning.steering is None and meaning.lane is None and not meaning.bare_sides \
        and not re.search(r"\b(?:left|right)\b", s)
    if side in ("left", "right") and no_side_named and not meaning.question and meaning.emergency is None:
        if _OVERTAKE.search(s) and _CAR_AHEAD.search(s) and not plan.calls \
                and (offered is None or ToolName.OVERTAKE in offered):
            afterwards = "return" if _RETURN.search(s) else "keep"
            plan.calls.append((str(ToolName.OVERTAKE), {"side": side, "afterwards": afterwards}))
            _note(plan, f"Overtaking on the {side}, as you prefer.")
        elif _EVADE.search(s) and ToolName.SET_PREFERRED_STEERING_DIRECTION not in names \
                and not any(lane_of_tool(n) for n in names):
            plan.calls.append((str(ToolName.SET_PREFERRED_STEERING_DIRECTION), {DIRECTION_ARGUMENT: side}))
            _note(plan, f"Evading on the {side}, as you prefer.")
    yield_side = preferences.get("yield_side")
    if yield_side in ("left", "right") and meaning.emergency == "yield" and no_side_named:
        if any(n.startswith("Following ") for n in plan.notes):
            _note(plan, f"You prefer pulling over to the {yield_side}; the traffic rule I followed decides here.")
        else:
            for index, (name, arguments) in enumerate(plan.calls):
                if lane_of_tool(str(name)) is not None and lane_of_tool(str(name)) != yield_side:
                    plan.calls[index] = (lane_tool_name(yield_side), arguments)
                    _note(plan, f"Pulling over to the {yield_side}, as you prefer.")
    cap = preferences.get("max_speed_mps")
    if isinstance(cap, int | float) and math.isfinite(cap) and not meaning.emergency:
        named = [p.value_mps for p in meaning.speeds if p.mode in ("set", "floor") and not p.negated]
        for index, (name, arguments) in enumerate(plan.calls):
            v = arguments.get(SPEED_ARGUMENT)
            if not isinstance(v, int | float) or v <= cap + 1e-6:
                continue
            if not (str(name) in _SPEED_TOOLS or lane_of_tool(str(name))):
                continue
            if named:
                _note(plan, f"That is above the {cap:g} m/s you told me you prefer; doing as you say now.")
            else:
                plan.calls[index] = (name, {**arguments, SPEED_ARGUMENT: round(cap, 2)})
                _note(plan, f"Keeping to {round(cap, 2):g} m/s ({cap * 3.6:.0f} km/h), the most you told me you like.")
