"""The agent's system message (tau = 0): its role, (A) the initially attached primitives and (B) the tools,
as in the paper's "Agent Setup", so that the agent can restore the original specification; then the road
(from the server's ``sumo://road``: lanes, handedness, edge lane, speed limit, what yielding and resuming
mean there). Without a road (an older server) the message says nothing about it."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from agentic_mpc.agent.backends.base import ToolSpec


def _describe_primitive(primitive: dict[str, Any]) -> str:
    params = []
    for key, value in primitive.items():
        if key in ("kind", "symbol"):
            continue
        if isinstance(value, list):
            value = f"{len(value)} item(s)"
        params.append(f"{key}={value}")
    return f"- {primitive.get('kind')} ({primitive.get('symbol')}): {', '.join(params)}"


def _describe_tool(tool: ToolSpec) -> str:
    args = []
    for name, prop in tool.input_schema.get("properties", {}).items():
        kind = prop.get("type", "value")
        if "enum" in prop:
            kind = " | ".join(map(repr, prop["enum"]))
        elif "minimum" in prop or "maximum" in prop:
            kind = f"{kind} in [{prop.get('minimum', '-inf')}, {prop.get('maximum', 'inf')}]"
        args.append(f"{name}: {kind}")
    return f"- {tool.name}({', '.join(args)}): {tool.description}"


def _text(value: Any) -> str:
    return value.strip() if isinstance(value, str) else ""


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def describe_road(road: dict[str, Any] | None) -> list[str]:
    """The road section of the system message from ``sumo://road`` JSON; no lines if there is none or it
    is not understood (then the model knows nothing of the road, as before the resource existed)."""
    if not isinstance(road, dict) or not isinstance(road.get("lanes"), list):
        return []
    facts = []
    if traffic := _text(road.get("traffic")):
        keep_to = _text(road.get("keep_to"))
        facts.append(f"{traffic} traffic" + (f" (vehicles keep to the {keep_to})" if keep_to else ""))
    road_type = _text(road.get("road_type"))
    if (limit := _number(road.get("speed_limit_mps"))) is not None:
        what = f"a {road_type} with no speed signed, the fastest the tools accept" if road_type else "speed limit"
        facts.append(f"{what} {limit:g} m/s ({limit * 3.6:g} km/h)")
    head = f"The road: {'; '.join(facts)}." if facts else "The road."
    lines = [head, "Lanes (by the names the tools use), from the road edge outwards:"]
    for lane in road["lanes"]:
        if not isinstance(lane, dict) or not _text(lane.get("name")):
            continue
        facts = [f"index {lane['index']}" if _number(lane.get("index")) is not None else "",
                 _text(lane.get("tool"))]
        detail = ", ".join(fact for fact in facts if fact)
        role = _text(lane.get("role"))
        lines.append(f"- {_text(lane['name'])} lane{f' ({detail})' if detail else ''}{f': {role}' if role else ''}")
    if len(lines) == 2:
        return []
    if edge := _text(road.get("edge_lane")):
        lines.append(f"The edge lane is the {edge} lane.")
    lines += [text for key in ("yield", "resume") if (text := _text(road.get(key)))]
    if jurisdiction := _text(road.get("jurisdiction")):
        lines.append(f"Jurisdiction: {jurisdiction}: its traffic rules apply (how to make way for an emergency "
                     "vehicle, speed limits); look them up with a knowledge search tool where there is one and "
                     "cite the document you follow.")
        if road_type:
            lines.append(f"Before setting a speed, look up the speed limit for a {road_type} in {jurisdiction} and "
                         "keep to it (the tools accept up to the road's design speed).")
    return lines


def system_prompt(
    initial: dict[str, Any] | None, tools: Sequence[ToolSpec], extra: str = "", road: dict[str, Any] | None = None
) -> str:
    """The system message: role, (A) the initially attached primitives, (B) the tools (paper, "Agent Setup"),
    then the road (``sumo://road``, if given)."""
    lines = [
        "You are the driving agent of an autonomous car. A model predictive controller drives the car; its "
        "control specification is a sum of primitive objective functions. You change the specification only "
        "by calling the tools below. Call a tool only when the specification must change; otherwise answer "
        "briefly without calling any tool. Speeds are in m/s (1 m/s = 3.6 km/h; 1 mph = 0.447 m/s).",
        "",
        "Initially attached primitives (the original specification; restore it when a temporary situation is over):",
    ]
    attached = (initial or {}).get("attached", [])
    lines += [_describe_primitive(p) for p in attached if p.get("kind") != "mandatory"] or ["- (unknown)"]
    lines += ["", "Available tools:"] + [_describe_tool(t) for t in tools]
    search = next((t.name for t in tools if t.name.endswith("__search_knowledge")), None)
    if search is not None:  # a knowledge server among the agent's: say when to use it (models answered from memory)
        lines += ["", f"Knowledge: for a question about traffic rules, speed limits, making way for an emergency "
                      f"vehicle or this car, first call {search} with the question, then answer from the passages "
                      "it returns and name the document id you used (for example jp-traffic-rules)."]
    if road_lines := describe_road(road):  # last: what a small model reads just before the passenger's message
        lines += ["", *road_lines]
    if extra:
        lines += ["", extra]
    return "\n".join(lines)


def _settings(primitive: dict[str, Any]) -> dict[str, Any]:
    """What a tool sets in a primitive: its scalar parameters (lists such as obstacles are the world's)."""
    return {key: value for key, value in primitive.items()
            if key not in ("kind", "symbol") and not isinstance(value, list | dict)}


def _by_kind(specification: dict[str, Any] | None) -> dict[str, dict[str, Any]]:
    attached = (specification or {}).get("attached")
    return {p["kind"]: _settings(p) for p in attached or [] if isinstance(p, dict)
            and isinstance(p.get("kind"), str) and p["kind"] != "mandatory"}


def shown_value(value: Any) -> str:
    """A setting as the model reads it (floats without trailing zeros)."""
    return f"{value:g}" if isinstance(value, float) else str(value)


def specification_changes(initial: dict[str, Any] | None, current: dict[str, Any] | None) -> list[str]:
    """How ``current`` differs from ``initial`` (``mpc://specification`` JSON), one short phrase per primitive:
    ``path_tracking: lane=left (initially center), v_ref_mps=0 (initially 15)``; none if either is unknown."""
    if not isinstance(initial, dict) or not isinstance(current, dict):
        return []
    before, now = _by_kind(initial), _by_kind(current)
    changes = []
    for kind, settings in now.items():
        if kind not in before:
            shown = ", ".join(f"{key}={shown_value(value)}" for key, value in settings.items())
            changes.append(f"{kind}({shown}) is attached (not initially)")
            continue
        differing = [f"{key}={shown_value(value)} (initially {shown_value(before[kind].get(key))})"
                     for key, value in settings.items() if before[kind].get(key) != value]
        if differing:
            changes.append(f"{kind}: {', '.join(differing)}")
    changes += [f"{kind} is detached (initially attached)" for kind in before if kind not in now]
    return changes


def restore_note(changes: list[str]) -> str:
    """The agent's one reminder in a step whose answer changed nothing while the specification differs from
    the initial one (:class:`~agentic_mpc.agent.agent.Agent`, ``AgentConfig.restore_reminder``)."""
    return ("Note from the agent, not the passenger: the specification is not the initial one ("
            + "; ".join(changes) + "). If the situation that needed this change is over, call the tool that "
            "restores the initial specification now; if it still holds, reply without a call.")
