"""The agent's system message (tau = 0): its role, (A) the initially attached primitives and (B) the tools,
as in the paper's "Agent Setup", so that the agent can restore the original specification."""

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


def system_prompt(initial: dict[str, Any] | None, tools: Sequence[ToolSpec], extra: str = "") -> str:
    """The system message: role, (A) the initially attached primitives, (B) the tools (paper, "Agent Setup")."""
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
    if extra:
        lines += ["", extra]
    return "\n".join(lines)
