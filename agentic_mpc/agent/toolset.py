"""The tools a language model is offered, and the unit layer between it and the MCP tools.

**Which tools** (:func:`offered`): a small model picks worse as the list grows (Qwen2.5-Coder-1.5B chose
``overtake`` for an ambulance from the 13-tool list, the paper's calls from the paper's tools). So the model is
offered the tools that apply to the road and scenario, ``toolset``:

- ``paper`` (and ``auto``, the default): what the paper's scenarios need, the lane tools of this road,
  ``set_reference_speed`` and the steering preference (``set_``/``clear_preferred_steering_direction``);
- ``lampilot``: those and LaMPilot's manoeuvres (``change_lane``, ``change_reference_speed``, the following
  distance, ``overtake``, ``pull_over`` where the road has a hard shoulder);
- ``all``: every tool the servers list.

The rest on request: a message that asks for a following distance, an overtake or the hard shoulder brings
those tools into that step (:data:`ON_REQUEST`). Another server's tools (the knowledge search) stay offered.
The MCP server lists every tool and the agent runs any of them: the subset is what the model is shown.

**Units** (:func:`model_facing`, :func:`converted`): the model gives a speed as the passenger said it, with a
``unit`` (``m/s``, ``km/h``, ``mph``), and this layer converts it to the m/s the MCP tools take, not trusting
the model's arithmetic (it passed 36 km/h as ``v_ref: 36``). A speed above the road's limit (the MCP schema's
maximum) with a unit is set to the limit and the answer says so, as the rules backend does; without a unit
it is refused by the schema check as before.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import Literal

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.messages import ToolCall
from agentic_mpc.mcp.protocol import ToolName, lane_of_tool

Toolset = Literal["auto", "paper", "lampilot", "all"]
TOOLSETS: tuple[str, ...] = ("auto", "paper", "lampilot", "all")

UNIT_ARGUMENT = "unit"
MPS_PER_UNIT = {"m/s": 1.0, "km/h": 1 / 3.6, "mph": 0.44704}
"""What one unit is in m/s."""
SPEED_ARGUMENTS = ("v_ref", "delta_v")
"""The tools' arguments in m/s (a speed, a change of speed)."""

PAPER = frozenset({ToolName.SET_REFERENCE_SPEED, ToolName.SET_PREFERRED_STEERING_DIRECTION,
                   ToolName.CLEAR_PREFERRED_STEERING_DIRECTION})
"""With the lane tools: what the paper's scenarios need."""
LAMPILOT = PAPER | {ToolName.CHANGE_LANE, ToolName.CHANGE_REFERENCE_SPEED, ToolName.SET_FOLLOWING_DISTANCE,
                    ToolName.CHANGE_FOLLOWING_DISTANCE, ToolName.CLEAR_FOLLOWING_DISTANCE, ToolName.OVERTAKE,
                    ToolName.PULL_OVER}
"""With the lane tools: LaMPilot's manoeuvres."""
ROUTES = frozenset({ToolName.TURN_AT_NEXT_JUNCTION, ToolName.DRIVE_TO})
"""Wherever the server offers them (a route through junctions): choosing the way."""

_FOLLOWING = (ToolName.SET_FOLLOWING_DISTANCE, ToolName.CHANGE_FOLLOWING_DISTANCE, ToolName.CLEAR_FOLLOWING_DISTANCE)
ON_REQUEST: tuple[tuple[re.Pattern[str], tuple[str, ...]], ...] = (
    (re.compile(r"follow|distance|\bgap\b|tailgat|\b\d+ ?(m|metres|meters) behind|behind (the|that) (car|truck|"
                r"vehicle)", re.IGNORECASE), _FOLLOWING),
    (re.compile(r"overtak|pass (the|that) (car|truck|vehicle|bus)|get past (the|that)", re.IGNORECASE), (ToolName.OVERTAKE,)),
    (re.compile(r"hard shoulder|emergency lane|\bshoulder\b", re.IGNORECASE), (ToolName.PULL_OVER,)),
    (re.compile(r"\b(one|next|a) lane (to the |over )?(left|right)|\bby \d+(\.\d+)? ?(m/s|km/h|mph|kmh)", re.IGNORECASE),
     (ToolName.CHANGE_LANE, ToolName.CHANGE_REFERENCE_SPEED)),
)
"""Words of a message that bring more tools into its step."""
_QUESTION = re.compile(r"\?\s*$")
_ASKING = re.compile(r"^\s*(could|can|would|will) you\b|\bplease\b", re.IGNORECASE)
"""A question that asks for something ("Could you overtake the truck?") is a request."""

SHORT = {
    ToolName.SET_REFERENCE_SPEED: "change the speed, keeping the lane",
    ToolName.SET_PREFERRED_STEERING_DIRECTION: "pass obstacles on that side",
    ToolName.CLEAR_PREFERRED_STEERING_DIRECTION: "no preferred side for obstacles",
    ToolName.CHANGE_LANE: "move one lane to that side, same speed",
    ToolName.KEEP_LANE: "drive in the lane with that index (0 = the edge lane)",
    ToolName.CHANGE_REFERENCE_SPEED: "speed up (delta_v > 0) or slow down (< 0) by delta_v",
    ToolName.SET_FOLLOWING_DISTANCE: "keep gap metres behind the car ahead",
    ToolName.CHANGE_FOLLOWING_DISTANCE: "change that gap by change metres (negative: closer)",
    ToolName.CLEAR_FOLLOWING_DISTANCE: "no following distance",
    ToolName.OVERTAKE: "overtake the car ahead on that side; afterwards 'keep' that lane or 'return'",
    ToolName.PULL_OVER: "pull over onto the hard shoulder and stop",
    ToolName.TURN_AT_NEXT_JUNCTION: "take the next junction left, right or straight on",
    ToolName.DRIVE_TO: "drive to that edge of the road network",
}
"""One line per tool for a small model (the MCP description is the full one)."""


def _is_other_server(tool: ToolSpec) -> bool:
    return "__" in tool.name


def base_names(tools: Sequence[ToolSpec], toolset: str) -> set[str]:
    """The names of the tools ``toolset`` offers on this road (every lane tool the server lists)."""
    if toolset == "all":
        return {t.name for t in tools}
    family = (LAMPILOT if toolset == "lampilot" else PAPER) | ROUTES
    return {t.name for t in tools if t.name in family or lane_of_tool(t.name) is not None or _is_other_server(t)}


def requested(message: str | None) -> set[str]:
    """The tools a message asks for by its words (:data:`ON_REQUEST`); none for a question ("On which side
    do you overtake in Japan?" asks for no overtake)."""
    if not message or (_QUESTION.search(message) and not _ASKING.search(message)):
        return set()
    return {str(name) for pattern, names in ON_REQUEST if pattern.search(message) for name in names}


def offered(tools: Sequence[ToolSpec], toolset: str = "auto", message: str | None = None) -> list[ToolSpec]:
    """The tools shown to the model, in the servers' order: ``toolset``'s and those ``message`` asks for."""
    names = base_names(tools, toolset) | requested(message)
    return [t for t in tools if t.name in names]


def speed_bound(tool: ToolSpec, argument: str) -> float | None:
    """The largest value the MCP schema accepts for ``argument`` (the road's limit for ``v_ref``)."""
    return tool.number_bounds(argument)[1]


def model_facing(tool: ToolSpec) -> ToolSpec:
    """``tool`` as a model sees it: a speed without the m/s bound and a ``unit`` beside it (required, so that
    the model says which unit the passenger used); a knowledge search with its query only."""
    schema = dict(tool.input_schema)
    properties = dict(schema.get("properties") or {})
    required = list(schema.get("required") or [])
    if _is_other_server(tool) and "query" in properties:
        return replace(tool, input_schema={"type": "object", "properties": {"query": properties["query"]},
                                           "required": ["query"]})
    speeds = [name for name in SPEED_ARGUMENTS if name in properties]
    if not speeds:
        return tool
    for name in speeds:
        prop = {key: value for key, value in properties[name].items() if key not in ("maximum", "minimum")}
        prop["description"] = "the number the passenger said, in its unit"
        if name == "v_ref":
            prop["minimum"] = 0
        properties[name] = prop
    properties[UNIT_ARGUMENT] = {"type": "string", "enum": list(MPS_PER_UNIT)}
    required = [*required, UNIT_ARGUMENT] if UNIT_ARGUMENT not in required else required
    return replace(tool, input_schema={**schema, "properties": properties, "required": required})


def signature(tool: ToolSpec) -> str:
    """``name(arg, arg)`` with enums spelled out: ``set_preferred_steering_direction(direction: left|right)``."""
    args = []
    for name, prop in (model_facing(tool).input_schema.get("properties") or {}).items():
        args.append(f"{name}: {'|'.join(map(str, prop['enum']))}" if "enum" in prop and name != UNIT_ARGUMENT
                    else name)
    return f"{tool.name}({', '.join(args)})"


def short_description(tool: ToolSpec) -> str:
    if tool.name in SHORT:
        return SHORT[tool.name]
    if (lane := lane_of_tool(tool.name)) is not None:
        return f"drive in the {lane} lane at v_ref (0: stop there)"
    if tool.name.endswith("__search_knowledge"):
        return "look up traffic rules or the car's manual, only for what the passages given with a message miss"
    first = re.split(r"(?<=[.:;])\s", tool.description.removeprefix(f"[{tool.name.split('__')[0]}] "))[0]
    return first.rstrip(".:;")


def converted(call: ToolCall, tools: Iterable[ToolSpec],
              law_limit: tuple[float, str] | None = None) -> tuple[ToolCall, str | None]:
    """``call`` with its speeds in m/s (the ``unit`` it gave, m/s if none) and, given with a unit, set to the
    limit if above it; the note says so (None: nothing to say). Without a unit a speed above the limit is left
    for the schema check to refuse, as before. Calls without a speed, or unreadable, are left as they are.
    ``law_limit``: (m/s, where it comes from) the law's limit for this road where it is below the road's (a
    jurisdiction's motorway without signs: agent/retrieval.py looks it up), kept to in the same way."""
    listed = {t.name: t for t in tools}
    tool = listed.get(call.name)
    arguments = call.arguments
    if tool is None or call.error is not None or not isinstance(arguments, dict):
        return call, None
    speeds = [name for name in SPEED_ARGUMENTS if name in (tool.input_schema.get("properties") or {})]
    if not speeds:
        return call, None
    arguments = dict(arguments)
    stated = UNIT_ARGUMENT in arguments  # a speed with its unit is the passenger's: kept to the limit
    unit = arguments.pop(UNIT_ARGUMENT, "m/s")
    factor = MPS_PER_UNIT.get(str(unit).strip().lower().replace("kph", "km/h").replace("kmh", "km/h"))
    if factor is None:
        return replace(call, error=f"unit must be one of {', '.join(MPS_PER_UNIT)}, got {unit!r}"), None
    notes = []
    for name in speeds:
        value = arguments.get(name)
        if isinstance(value, bool) or not isinstance(value, int | float):
            continue
        mps = round(float(value) * factor, 3)
        bound, whose = speed_bound(tool, name), "this road's limit"
        if law_limit is not None and (bound is None or law_limit[0] < bound):
            bound, whose = law_limit[0], f"the law's limit here ({law_limit[1]})"
        if stated and name == "v_ref" and bound is not None and mps > bound + 1e-9:
            notes.append(f"{value:g} {unit} is {mps:g} m/s, above {whose} of {bound:g} m/s "
                         f"({bound * 3.6:.0f} km/h): set to the limit.")
            mps = float(bound)
        arguments[name] = int(mps) if mps == int(mps) else mps
    return replace(call, arguments=arguments), " ".join(notes) or None
