"""The one table of the controller's MCP tools.

A tool is one :class:`~agentic_mpc.mcp.tools.ControllerTools` method marked ``@tool(ToolName.X)`` (or
``@lane_tool``, one tool per lane label of the ego's road, named by
:func:`~agentic_mpc.mcp.protocol.lane_tool_name`). What is said of it there is all there is: its name comes
from the protocol, its docstring is the description the model reads (``{lane}`` filled in for a lane tool),
and its annotated arguments are the JSON schema the server publishes and checks. :data:`SpeedMps` is bounded
to [0, the road's speed limit] when a server registers the tool, since the limit is the road's.

The server (:mod:`agentic_mpc.mcp.server`) registers :func:`instances` of :data:`TABLE`; a new tool is one
decorated method (and its name in :class:`~agentic_mpc.mcp.protocol.ToolName`); a subclass of
``ControllerTools`` adds tools of its own the same way.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Annotated, Any, Literal, get_args, get_origin

from pydantic import Field

from agentic_mpc.mcp.protocol import ToolName, lane_tool_name


class ToolCallError(ValueError):
    """A tool call the controller refuses; the message says why, for the agent and the transcript."""


@dataclass(frozen=True, slots=True)
class _SpeedLimited:
    """Marks an argument in m/s bounded by the road's speed limit (filled in at registration)."""

    description: str


SpeedMps = Annotated[float, _SpeedLimited("reference speed in m/s, from 0 (stop) to the road speed limit {limit:g} m/s")]
"""A speed argument in m/s, from 0 to the road's speed limit."""
Side = Annotated[Literal["left", "right"], Field(description="the side to evade obstacles to")]
"""``left`` or ``right``."""

PAPER_LANES = ("center", "left", "right")
"""The order the paper's lane tools are listed in (other labels follow, sorted)."""


@dataclass(frozen=True, slots=True)
class ToolDefinition:
    """One row of the table: the method, and its name (None for a lane tool: one per lane)."""

    name: str | None
    method: Callable[..., dict[str, Any]]
    available: Callable[[Any], bool] | None = None
    """Whether the road of ``tools`` has what the tool needs (``pull_over``: an emergency lane); None: always."""

    @property
    def per_lane(self) -> bool:
        return self.name is None

    def description(self, lane: str | None = None) -> str:
        text = " ".join(inspect.getdoc(self.method).split())
        return text.format(lane=lane) if lane is not None else text

    def bind(self, tools: Any, lane: str | None) -> Callable[..., dict[str, Any]]:
        """The tool's call on ``tools`` (keyword arguments as the schema names them, plus ``apply_at_s``)."""
        method = getattr(tools, self.method.__name__)
        if lane is None:
            return method
        return lambda **arguments: method(lane, **arguments)

    def parameters(self, speed_limit_mps: float) -> list[inspect.Parameter]:
        """The MCP arguments: the method's, but ``self``, ``lane`` and ``apply_at_s``, speed bounds filled in."""
        signature = inspect.signature(self.method, eval_str=True)
        return [parameter.replace(annotation=_bounded(parameter.annotation, speed_limit_mps),
                                  kind=inspect.Parameter.KEYWORD_ONLY)
                for name, parameter in signature.parameters.items() if name not in ("self", "lane", "apply_at_s")]


TABLE: list[ToolDefinition] = []
"""Every tool, in the order ``tools/list`` gives them."""


def tool(name: str, available: Callable[[Any], bool] | None = None
         ) -> Callable[[Callable[..., dict[str, Any]]], Callable[..., dict[str, Any]]]:
    """Register a ``ControllerTools`` method as the tool ``name`` (a :class:`ToolName` member), published
    where ``available(tools)`` holds (default: everywhere)."""

    def register(method: Callable[..., dict[str, Any]]) -> Callable[..., dict[str, Any]]:
        TABLE.append(ToolDefinition(str(name), method, available))
        return method

    return register


def lane_tool(method: Callable[..., dict[str, Any]]) -> Callable[..., dict[str, Any]]:
    """Register a ``ControllerTools`` method ``(self, lane, ...)`` as one tool per lane of the road."""
    TABLE.insert(sum(1 for d in TABLE if d.per_lane), ToolDefinition(None, method))  # lane tools first
    return method


def ordered_lanes(labels: Iterable[str]) -> list[str]:
    """Lane labels with the paper's three first, in its order, then the others sorted."""
    labels = set(labels)
    return [lane for lane in PAPER_LANES if lane in labels] + sorted(labels - set(PAPER_LANES))


def instances(tools: Any) -> list[tuple[str, ToolDefinition, str | None]]:
    """(tool name, definition, lane or None) of every tool of ``tools`` (a ``ControllerTools``) on its road:
    the rows whose method it has (a subclass adds its own), lane tools once per lane of the road."""
    lanes = ordered_lanes(tools.road().lanes)
    rows: list[tuple[str, ToolDefinition, str | None]] = []
    order = [str(name) for name in ToolName]  # the paper's tools first, whichever module registered first
    for definition in sorted(TABLE, key=lambda d: -1 if d.per_lane else
                             order.index(d.name) if d.name in order else len(order)):
        if getattr(type(tools), definition.method.__name__, None) is not definition.method:
            continue
        if definition.available is not None and not definition.available(tools):
            continue
        if definition.per_lane:
            rows += [(lane_tool_name(lane), definition, lane) for lane in lanes]
        else:
            rows.append((str(definition.name), definition, None))
    return rows


def _bounded(annotation: Any, speed_limit_mps: float) -> Any:
    if get_origin(annotation) is not Annotated:
        return annotation
    base, *metadata = get_args(annotation)
    marker = next((m for m in metadata if isinstance(m, _SpeedLimited)), None)
    if marker is None:
        return annotation
    field = Field(ge=0.0, le=speed_limit_mps, strict=True, allow_inf_nan=False,
                  description=marker.description.format(limit=speed_limit_mps))
    return Annotated[base, field]
