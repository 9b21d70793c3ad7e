"""The tools that choose the way where a world has junctions (``sumo://route`` says what the next junction
offers): take the next junction left, right or straight on, or drive to an edge of the network. They plan with
the world's :class:`~agentic_mpc.world.routes.RoutePlanner` and refuse, with what the junction offers, a way that
is not there (the car keeps its route). The new route is driven from the world's next step; J1 keeps its speed
and follows the new route's path."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field

from agentic_mpc.mcp.maneuvers import path_tracking_like
from agentic_mpc.mcp.protocol import ToolName
from agentic_mpc.mcp.tool_table import ToolCallError, tool
from agentic_mpc.primitives import PathTracking, Specification
from agentic_mpc.world.routes import RoutePlanner, RouteRefused

Direction = Annotated[Literal["left", "right", "straight"],
                      Field(description="the way to take at the next junction: left, right or straight on")]
EdgeId = Annotated[str, Field(min_length=1, max_length=200, description="an edge of the network (sumo://route)")]


def _has_routes(tools: Any) -> bool:
    return getattr(tools, "route_planner", None) is not None


class RouteTools:
    """Mixed into :class:`~agentic_mpc.mcp.tools.ControllerTools` (``slot``, ``road()``, ``_apply``); wired to a
    world by setting :attr:`route_planner`."""

    route_planner: RoutePlanner | None = None

    @tool(ToolName.TURN_AT_NEXT_JUNCTION, available=_has_routes)
    def turn_at_next_junction(self, direction: Direction, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Take the next junction ahead to the left, to the right or straight on (then straight on while the road
        continues); refused, with the directions it offers, where the junction has no such way."""
        if direction not in ("left", "right", "straight"):
            raise ToolCallError(f"direction must be 'left', 'right' or 'straight', got {direction!r}")
        return self._route(ToolName.TURN_AT_NEXT_JUNCTION, {"direction": direction},
                           lambda planner: planner.plan_turn(direction), apply_at_s)

    @tool(ToolName.DRIVE_TO, available=_has_routes)
    def drive_to(self, edge: EdgeId, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Drive to this edge of the network by the fastest way from here (SUMO's router)."""
        return self._route(ToolName.DRIVE_TO, {"edge": edge}, lambda planner: planner.plan_destination(edge),
                           apply_at_s)

    def _route(self, name: str, arguments: dict[str, Any], plan: Any, apply_at_s: float | None) -> dict[str, Any]:
        planner = self.route_planner
        if planner is None:
            raise ToolCallError("this road has no junctions to choose a way at")
        try:
            planned = plan(planner)
        except RouteRefused as error:
            raise ToolCallError(f"{error}; the car keeps its route") from None

        def change(spec: Specification) -> Specification:
            path = planner.follow(planned)
            current = spec.get(PathTracking.kind)
            speed = current.v_ref_mps if isinstance(current, PathTracking) else self.road().speed_limit_mps
            return spec.attach(path_tracking_like(spec, path=path, lane="center", v_ref_mps=speed))

        return self._apply(name, arguments, change, apply_at_s)  # type: ignore[attr-defined]
