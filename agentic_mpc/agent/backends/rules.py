"""The embedded offline backend: a deterministic, rule-based interpreter. It is NOT a language model.

It stands in for the paper's LLM where none is available (tests, ``agentic-mpc ask`` by default, offline
demos). It understands a small grammar of driving requests and nothing else; for anything it does not
recognise it makes no tool call and says so. Use the ``openai`` backend for a real model.

The grammar
-----------
A message is normalised (lower case, contractions expanded: "don't" -> "do not"), split into clauses at
sentence punctuation, commas, "but", "and then"; "rather than X" / "instead of X" become "not X". In each
clause it finds:

- sides: "left" / "right" where they name a side (not "right now", "the ambulance left"); a negation earlier
  in the clause ("not", "never", "no", "without", "avoid passing ...") flips the side; "keep the obstacle on
  our left" means evading to the right;
- lanes: "left/right/center/middle lane", "change lanes to the left", "back to our lane";
- speeds: a number (digits or words) with a unit: km/h (kph, kmh, kilometres per hour), mph (miles per
  hour), m/s (mps, metres per second); "by X" is relative, "at most / no faster than / under X" caps,
  "at least X" floors; "stop" / "halt" / "pull over" is 0; "slow down" / "speed up" without a number scale
  the current reference speed by 0.75 / 1.25;
- emergency vehicles (ambulance, fire engine, police car, siren, ...): coming, behind, approaching or "let
  them pass" means yield (the yield lane, default left as in the paper, at 0 m/s unless a side or a speed
  is given; "without stopping", "don't stop", "keep rolling" ask for a crawl, ``YIELD_ROLLING_MPS``,
  instead: SUMO's emergency vehicles slow to 20 km/h past a car stopped beside them); gone, passed, went
  by, all clear, false alarm means resume: the INITIAL specification's lane and speed, read from the
  system message;
- resume / restore ("carry on", "back to normal", "reset to the original settings");
- no preference ("either side is fine", "forget the steering preference").

Intents map to tools: yield/resume/lane -> ``run_<lane>_lane(v_ref)`` (the current speed unless one is
given; a stopped car changing lane uses the initial speed), speed -> ``set_reference_speed``, side ->
``set_preferred_steering_direction``, no preference -> ``clear_preferred_steering_direction``. Speeds above
the tool's schema maximum are clamped to it (and the reply says so). Questions ("which lane are we in?"),
conditions about the future ("if an ambulance comes, ...") and small talk give no tool call; the reply
describes the current specification. After tool results it answers with a summary and no call, so the
agent step ends.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from pydantic import Field

from agentic_mpc.agent.backends import rules_knowledge as knowledge
from agentic_mpc.agent.backends import rules_speeds as speeds
from agentic_mpc.agent.backends import rules_understanding as understanding
from agentic_mpc.agent.backends.base import BackendReply, ToolSpec
from agentic_mpc.agent.backends.rules_lexicon import (
    KMH_TO_MPS,
    LANE_NAMES,
    MPH_TO_MPS,
    SLOW_DOWN_FACTOR,
    SPEED_UP_FACTOR,
    YIELD_ROLLING_MPS,
    Side,
)
from agentic_mpc.agent.backends.rules_maneuvers import maneuver_call
from agentic_mpc.agent.backends.rules_parsing import (
    Interpretation,
    SideMention,
    SpeedPhrase,
    clauses,
    explain,
    interpret,
    normalise,
    side_mentions,
    speed_phrases,
)
from agentic_mpc.agent.backends.rules_state import DrivingState, driving_states
from agentic_mpc.agent.config import AgentRunSettings
from agentic_mpc.agent.memory_rules import apply_memory
from agentic_mpc.agent.messages import Message, ToolCall
from agentic_mpc.mcp.protocol import DIRECTION_ARGUMENT, SPEED_ARGUMENT, ToolName, lane_tool_name

__all__ = [
    "KMH_TO_MPS",
    "LANE_NAMES",
    "MPH_TO_MPS",
    "SLOW_DOWN_FACTOR",
    "SPEED_UP_FACTOR",
    "DrivingState",
    "Interpretation",
    "Plan",
    "RulesBackend",
    "RulesSettings",
    "Side",
    "SideMention",
    "SpeedPhrase",
    "clauses",
    "explain",
    "interpret",
    "normalise",
    "side_mentions",
    "speed_phrases",
]


@dataclass
class Plan:
    calls: list[tuple[str, dict[str, Any]]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    not_understood: list[str] = field(default_factory=list)
    """The parts of the message that ask for something no rule reads (then there are no calls)."""
    said_back: list[str] = field(default_factory=list)
    """What of the request cannot be met and why (a speed above the limit): repeated when the calls are done."""


class RulesBackend:
    """Deterministic stand-in for an LLM (see the module docstring). ``yield_lane`` is where it pulls over
    for emergency vehicles: "left" as in the paper (left-hand traffic); use "right" for right-hand traffic."""

    name = "rules"
    reads_situation = False  # it reads the message alone

    def __init__(self, yield_lane: Side = "left") -> None:
        self.yield_lane = yield_lane
        self._counter = 0
        self._said_back: list[str] = []

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        return self.reply(history, tools)

    async def aclose(self) -> None:
        return None

    def reply(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        if not history:
            return BackendReply("Nothing to answer.")
        last = history[-1]
        initial, current = driving_states(history)
        if last.role == "tool" and last.name == knowledge.SEARCH_TOOL and not last.is_error:
            asked = next((m for m in reversed(history) if m.role == "user"), None)
            if asked is not None:  # the rule looked up: now the call it calls for
                plan = self.plan(asked.content, initial, current, {t.name: t for t in tools},
                                 jurisdiction=knowledge.jurisdiction_of(history),
                                 road_type=knowledge.road_type_of(history), found=last.content)
                return self._reply(apply_memory(plan, asked, [t.name for t in tools]), current)
        if last.role == "tool":
            return BackendReply(self._summarise_results(history, current))
        if last.role != "user":
            return BackendReply("Waiting for a message.")
        plan = self.plan(last.content, initial, current, {t.name: t for t in tools},
                         jurisdiction=knowledge.jurisdiction_of(history), road_type=knowledge.road_type_of(history))
        return self._reply(apply_memory(plan, last, [t.name for t in tools]), current)  # earlier runs' passenger

    def _reply(self, plan: Plan, current: DrivingState) -> BackendReply:
        self._said_back = plan.said_back if plan.calls else []  # for the passenger, once the calls are done
        calls = tuple(self._call(name, args) for name, args in plan.calls)
        if calls:
            described = ", ".join(
                f"{name}({', '.join(f'{k}={v!r}' for k, v in args.items())})" for name, args in plan.calls
            )
            text = " ".join([f"Calling {described}.", *plan.notes])
        else:
            text = " ".join([*plan.notes, f"No change to the control specification: {current.describe()}."])
        return BackendReply(text.strip(), calls)

    def _call(self, name: str, arguments: dict[str, Any]) -> ToolCall:
        self._counter += 1
        return ToolCall.of(f"rules-{self._counter}", name, arguments)

    def plan(
        self, text: str, initial: DrivingState, current: DrivingState, tools: dict[str, ToolSpec],
        jurisdiction: str | None = None, found: str | None = None, road_type: str | None = None,
    ) -> Plan:
        """The tool calls for one message, given the initial and current driving state; with a
        ``jurisdiction`` and a knowledge search tool a yield first looks the rule up (``found``: its result),
        and so does a speed where the road names its ``road_type`` (the limit for it caps the speed)."""
        meaning = interpret(text)
        plan = Plan()
        missed = understanding.not_understood(text, tools, answered_as_such=meaning.question or meaning.conditional)
        if missed:  # a call from half a message is worse than none: say what was not understood
            plan.not_understood = missed
            plan.notes.append(understanding.describe(missed, english=not understanding.not_english(text)))
            return plan
        looked_up = None
        if meaning.emergency == "yield" and jurisdiction and knowledge.SEARCH_TOOL in tools:
            if found is None:
                plan.calls.append(knowledge.search_call(jurisdiction))
                plan.notes.append(f"Looking up how to make way for an emergency vehicle in {jurisdiction}.")
                return plan
            looked_up = knowledge.yield_rule(found, jurisdiction)
        if not meaning.question:
            call, note = maneuver_call(text, tools)
            if meaning.conditional and (call is None or call[0] != ToolName.TURN_AT_NEXT_JUNCTION):
                call = note = None  # "when we get to the crossroad, turn left" is what the turn tool does; no other
            if call is not None or note is not None:
                plan.calls += [call] if call is not None else []
                plan.notes += [note] if note is not None else []
                return plan
        if meaning.question:
            if knowledge.SEARCH_TOOL in tools and found is None:  # look it up, then answer citing it
                plan.calls.append(knowledge.question_call(text, jurisdiction))
                return plan
            answer = knowledge.answer_from(found, text) if found is not None else None
            plan.notes.append(answer or "That is a question; I answer it without changing anything.")
            return plan
        if meaning.conditional and meaning.steering not in ("left", "right", "clear"):
            plan.notes.append("I act on what is happening now; I do not keep instructions for later situations.")
            return plan

        v_max = speeds.speed_limit(tools)
        explicit = speeds.explicit_speed(meaning, current, initial)
        wanted = explicit if explicit is not None else speeds.relative_speed(meaning, current, initial)
        if (wanted or 0.0) > 0.0 and not (meaning.emergency or meaning.pull_over) and jurisdiction and road_type \
                and knowledge.SEARCH_TOOL in tools:
            if found is None:  # the limit of this type of road where it is: look it up first
                plan.calls.append(knowledge.limit_search_call(jurisdiction, road_type))
                plan.notes.append(f"Looking up the speed limit for a {road_type} in {jurisdiction}.")
                return plan
            if (rule := knowledge.speed_limit_rule(found, jurisdiction, road_type)) is not None:
                limit_mps, line, cite = rule
                v_max = limit_mps if v_max is None else min(v_max, limit_mps)
                plan.notes.append(f"Following {cite}: \"{line}\"")
        speed, speed_note = speeds.clamped(wanted, v_max)
        explicit_speed, _ = speeds.clamped(explicit, v_max)
        if speed_note:
            plan.notes.append(speed_note)
            plan.said_back.append(speed_note)

        lane_call: tuple[str, float | None] | None = None
        if meaning.emergency == "yield" or meaning.pull_over:
            # Emergency vehicles decide lane and speed: a stated speed, else a crawl if told not to stop, else 0.
            side = meaning.lane if meaning.lane in ("left", "right") else next(iter(meaning.bare_sides), None)
            rolling = meaning.emergency == "yield" and (meaning.keep_rolling or meaning.stop_negated)
            if explicit_speed is not None:
                v_yield = explicit_speed
            elif rolling:  # move over at a crawl: SUMO slows an emergency vehicle passing a stopped car
                v_yield = min(YIELD_ROLLING_MPS, current.v_ref_mps or YIELD_ROLLING_MPS)
            else:
                v_yield = 0.0
            lane_call = (side or self.yield_lane, v_yield)
            if looked_up is not None and side is None:  # the rule found decides where, and whether to stop
                how, cite = looked_up
                lane, stop = knowledge.yield_lane(how, current.lane)
                lane_call = (lane, v_yield if stop else min(YIELD_ROLLING_MPS, current.v_ref_mps or YIELD_ROLLING_MPS))
                plan.notes.append(f"Following {cite}.")
            plan.notes.append("Making way for the emergency vehicle." if meaning.emergency else "Pulling over.")
            if rolling and explicit_speed is None:
                plan.notes.append("Keeping a crawl in the yield lane instead of stopping.")
        elif meaning.emergency == "resume":
            lane_call = self._restore_lane(initial, explicit_speed)
            plan.notes.append("Resuming the original lane and speed.")
        elif meaning.emergency == "hold":
            plan.notes.append("Staying put until the emergency vehicle has passed.")
        elif meaning.emergency == "oncoming":
            plan.notes.append("The emergency vehicle is not in our direction of travel; nothing to change.")
        elif meaning.lane is not None:
            lane = initial.lane if meaning.lane == "initial" else meaning.lane
            v = speed if speed is not None else current.v_ref_mps
            if not v:  # changing lanes needs motion: a stopped car uses the original speed
                v = initial.v_ref_mps
            lane_call = (lane, v) if lane is not None else None
        elif meaning.restore_all:
            lane_call = self._restore_lane(initial, speed)
        elif meaning.resume:
            if (current.lane, current.v_ref_mps) != (initial.lane, initial.v_ref_mps) or speed is not None:
                lane_call = self._restore_lane(initial, speed)
            else:
                plan.notes.append("We are already driving as originally specified.")
        elif meaning.lane_negated_only:
            plan.notes.append("Understood which lane not to use; staying in the current lane.")

        if meaning.steering in ("left", "right"):
            plan.calls.append((ToolName.SET_PREFERRED_STEERING_DIRECTION, {DIRECTION_ARGUMENT: meaning.steering}))
        elif meaning.steering == "clear":
            plan.calls.append((ToolName.CLEAR_PREFERRED_STEERING_DIRECTION, {}))
        elif meaning.steering == "conflict":
            plan.notes.append("You mentioned both sides; please tell me which one to prefer.")
        elif meaning.restore_all and initial.steering != current.steering:
            if initial.steering is None:
                plan.calls.append((ToolName.CLEAR_PREFERRED_STEERING_DIRECTION, {}))
            else:
                plan.calls.append((ToolName.SET_PREFERRED_STEERING_DIRECTION, {DIRECTION_ARGUMENT: initial.steering}))

        if lane_call is not None and lane_call[1] is not None:
            lane, v = lane_call
            v = min(v, v_max) if v_max is not None else v
            plan.calls.append((lane_tool_name(lane), {SPEED_ARGUMENT: speeds.tidy(v)}))
        elif speed is not None and meaning.emergency is None:
            plan.calls.append((ToolName.SET_REFERENCE_SPEED, {SPEED_ARGUMENT: speeds.tidy(speed)}))
        if meaning.bare_number and not meaning.speeds:
            plan.notes.append("Please give the speed with a unit (km/h, mph or m/s).")
        if meaning.change_negated and speed is None:
            plan.notes.append("Keeping the current speed.")
        if meaning.stop_negated and speed is None and meaning.emergency != "yield":
            plan.notes.append("Not stopping.")
        if meaning.lane_unspecified and meaning.lane is None and lane_call is None:
            plan.notes.append("Which lane: left, center or right?")
        if not plan.calls and not plan.notes:
            plan.notes.append(
                "(I am a rule-based stand-in, not a language model: I understand lanes, speeds, the preferred side "
                "for evading obstacles, and emergency vehicles.)"
            )
        return plan

    def _restore_lane(self, initial: DrivingState, speed: float | None) -> tuple[str, float] | None:
        if initial.lane is None or initial.v_ref_mps is None:
            return None
        return initial.lane, speed if speed is not None else initial.v_ref_mps

    def _summarise_results(self, history: Sequence[Message], current: DrivingState) -> str:
        results = []
        for message in reversed(history):
            if message.role != "tool":
                break
            results.append(message)
        errors = [m for m in reversed(results) if m.is_error]
        if errors:
            detail = "; ".join(f"{m.name}: {m.content}" for m in errors)
            return f"The controller refused: {detail}. Now {current.describe()}."
        said_back = "".join(f" {note}" for note in self._said_back)
        return f"Done.{said_back} Now {current.describe()}."


class RulesSettings(AgentRunSettings):
    """The offline rule-based stand-in (deterministic, English; not a language model)."""

    backend: Literal["rules"] = "rules"
    yield_lane: Side | None = Field(None, description="where to pull over for emergency vehicles (default: the "
                                                      "road edge: left in left-hand traffic)")

    def build_backend(self, lefthand: bool) -> RulesBackend:
        return RulesBackend(yield_lane=self.yield_lane or ("left" if lefthand else "right"))
