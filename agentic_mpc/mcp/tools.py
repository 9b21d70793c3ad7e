"""The controller tools of the paper's "Agent Setup": methods that rewrite the control specification.

Each tool is said once, here: a method marked ``@tool`` / ``@lane_tool`` whose name (from
:mod:`~agentic_mpc.mcp.protocol`), docstring (the description a model reads) and annotated arguments (the
schema) are what the MCP server publishes (:mod:`~agentic_mpc.mcp.tool_table`). Each tool validates its
arguments, builds the new specification from the current one and swaps it into the
:class:`~agentic_mpc.primitives.SpecificationSlot` in one atomic ``slot.update`` (the control loop reads one
snapshot per step, so it never sees half a change). Each returns what is attached afterwards.

- ``run_<lane>_lane(v_ref)``, one per lane label of the ego's road (``run_center_lane``, ``run_left_lane``,
  ``run_right_lane`` on the paper's three-lane roads): attach J1 (path tracking) on that lane at ``v_ref``
  m/s; it replaces whichever path tracking was attached.
- ``set_reference_speed(v_ref)``: J1 on the lane currently tracked, at a new speed.
- ``set_preferred_steering_direction(direction)`` / ``clear_preferred_steering_direction()``: attach or
  detach J3.

The lanes come from a *lane source*, a callable returning :class:`~agentic_mpc.world.lanes.RoadLanes` (or a
plain ``(lanes, speed_limit_mps)`` tuple): the ego road's lane paths by label ("center", "left", "right"; a
road may have fewer) and its speed limit. Whoever wires the tools to a world passes one that reads that
world's road, so the tools know nothing of any world.

Timing: a tool applies its change at once, unless it is given ``apply_at_s`` (sim time). Then the change is
validated now, queued, and applied by :meth:`ControllerTools.apply_due`, which the simulation loop calls at
the start of every control step. The agent's ``lockstep`` mode uses this so that a decision taken while sim
time was frozen at t takes effect at t + latency, reproducibly.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from agentic_mpc.geometry import LanePath
from agentic_mpc.mcp.maneuvers import ManeuverTools, path_tracking_like, validated
from agentic_mpc.mcp.protocol import ToolName, lane_tool_name
from agentic_mpc.mcp.route_tools import RouteTools
from agentic_mpc.mcp.tool_table import Side, SpeedMps, ToolCallError, lane_tool, tool
from agentic_mpc.primitives import (
    PathTracking,
    PreferredSteeringDirection,
    Specification,
    SpecificationError,
    SpecificationSlot,
)
from agentic_mpc.world.lanes import RoadLanes, Situation

logger = logging.getLogger(__name__)

PATH_TRACKING = PathTracking.kind
STEERING_PREFERENCE = PreferredSteeringDirection.kind

LaneSource = Callable[[], RoadLanes | tuple[Mapping[str, LanePath], float]]
SituationSource = Callable[[], Situation]
SpecificationChange = Callable[[Specification], Specification]


@dataclass(frozen=True, slots=True)
class PendingChange:
    """A validated change waiting for its sim time (lockstep mode)."""

    apply_at_s: float
    sequence: int
    tool: str
    arguments: dict[str, Any]
    change: SpecificationChange

    def describe(self) -> dict[str, Any]:
        return {"apply_at_s": self.apply_at_s, "tool": self.tool, "arguments": self.arguments}


def attached_summary(specification: Specification) -> list[dict[str, Any]]:
    """The attached primitives as JSON-ready dicts, the mandatory one first."""
    return specification.describe()


class ControllerTools(ManeuverTools, RouteTools):
    """The tools over one specification slot, one lane source and (for the manoeuvre tools of
    :mod:`agentic_mpc.mcp.maneuvers`) one situation source: the ego's lane, speed and leader now.

    ``steering_template`` sets the parameters (form, weight, ...) J3 is attached with; only its direction is
    the agent's to choose. Path tracking keeps the weights of the one it replaces.
    """

    def __init__(
        self,
        slot: SpecificationSlot,
        lane_source: LaneSource,
        steering_template: PreferredSteeringDirection | None = None,
        situation_source: SituationSource | None = None,
    ) -> None:
        self.slot = slot
        self.lane_source = lane_source
        self.situation_source = situation_source
        self.steering_template = steering_template
        self._pending: list[tuple[float, int, PendingChange]] = []
        self._pending_lock = threading.Lock()
        self._sequence = itertools.count()
        self.speed_ceiling_mps: float | None = None
        """The fastest speed the tools accept instead of the road's limit (a benchmark that asks past it, as
        LaMPilot's does: ``agentic-mpc lampilot --speed-requests as_asked``); None: the road's limit."""

    # ------------------------------------------------------------------ road
    def road(self) -> RoadLanes:
        value = self.lane_source()
        road = value if isinstance(value, RoadLanes) else RoadLanes(*value)
        if not math.isfinite(road.speed_limit_mps) or road.speed_limit_mps <= 0:
            raise ToolCallError(f"the lane source gave an invalid speed limit {road.speed_limit_mps!r}")
        return road if self.speed_ceiling_mps is None else road._replace(speed_limit_mps=self.speed_ceiling_mps)

    def situation(self) -> Situation:
        """The ego's situation now; a ToolCallError where the tools were given no situation source."""
        if self.situation_source is None:
            raise ToolCallError("this tool needs to know the car's lane and the car ahead, which this setup does not tell")
        return self.situation_source()

    def check_speed(self, v_ref: Any, road: RoadLanes | None = None) -> float:
        """``v_ref`` as a float in [0, road speed limit], or a ToolCallError saying what is wrong."""
        if isinstance(v_ref, bool) or not isinstance(v_ref, int | float):
            raise ToolCallError(f"v_ref must be a number in m/s, got {type(v_ref).__name__} {v_ref!r}")
        v = float(v_ref)
        if not math.isfinite(v):
            raise ToolCallError(f"v_ref must be a finite number in m/s, got {v_ref!r}")
        limit = (road or self.road()).speed_limit_mps
        if v < 0 or v > limit + 1e-9:
            raise ToolCallError(f"v_ref = {v:g} m/s is outside [0, {limit:g}] m/s (0 to the road speed limit)")
        return v

    # ------------------------------------------------------------------ tools (docstrings: what a model reads)
    @lane_tool
    def run_lane(self, lane: str, v_ref: SpeedMps, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Drive on the {lane} lane at reference speed v_ref (m/s): attaches the path tracking objective (J1)
        with the {lane} lane as reference path and detaches the other path tracking. v_ref = 0 stops the
        car on that lane."""
        road = self.road()
        v = self.check_speed(v_ref, road)
        path = road.lanes.get(lane)
        if path is None:
            raise ToolCallError(
                f"the ego's road has no {lane} lane here (lanes: {', '.join(sorted(road.lanes)) or 'none'})"
            )

        def change(spec: Specification) -> Specification:
            return spec.attach(path_tracking_like(spec, path=path, lane=lane, v_ref_mps=v))

        return self._apply(lane_tool_name(lane), {"v_ref": v}, change, apply_at_s)

    @tool(ToolName.SET_REFERENCE_SPEED)
    def set_reference_speed(self, v_ref: SpeedMps, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Change the reference speed v_ref (m/s) of the path tracking objective (J1), keeping the lane the
        car follows now."""
        # The lane tracked once the pending changes are in (the change runs on that specification).
        road = self.road()
        v = self.check_speed(v_ref, road)

        def change(spec: Specification) -> Specification:
            current = spec.get(PATH_TRACKING)
            if not isinstance(current, PathTracking):
                # Nothing tracked yet: follow the centre lane, the paper's default.
                path = road.lanes.get("center")
                if path is None:
                    raise ToolCallError("no path tracking is attached and the road has no center lane")
                return spec.attach(path_tracking_like(spec, path=path, lane="center", v_ref_mps=v))
            # The lane source may know a fresher path for the same label (the ego moved to another road).
            path = road.lanes.get(current.lane, current.path)
            return spec.attach(path_tracking_like(spec, path=path, lane=current.lane, v_ref_mps=v))

        return self._apply(ToolName.SET_REFERENCE_SPEED, {"v_ref": v}, change, apply_at_s)

    @tool(ToolName.SET_PREFERRED_STEERING_DIRECTION)
    def set_preferred_steering_direction(self, direction: Side, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Prefer evading obstacles to the given side ('left' or 'right'): attaches the preferred steering
        direction objective (J3)."""
        if direction not in ("left", "right"):
            raise ToolCallError(f"direction must be 'left' or 'right', got {direction!r}")

        def change(spec: Specification) -> Specification:
            template = spec.get(STEERING_PREFERENCE) or self.steering_template
            fields = template.model_dump() if template is not None else {}
            fields["direction"] = direction
            return spec.attach(validated(PreferredSteeringDirection, fields))

        return self._apply(ToolName.SET_PREFERRED_STEERING_DIRECTION, {"direction": direction}, change, apply_at_s)

    @tool(ToolName.CLEAR_PREFERRED_STEERING_DIRECTION)
    def clear_preferred_steering_direction(self, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Remove the preferred steering direction objective (J3): evade on whichever side is best."""
        # Detaching what is not attached is not an error: the call is idempotent.

        def change(spec: Specification) -> Specification:
            return spec.detach(STEERING_PREFERENCE) if STEERING_PREFERENCE in spec else spec

        return self._apply(ToolName.CLEAR_PREFERRED_STEERING_DIRECTION, {}, change, apply_at_s)

    # ------------------------------------------------------------------ application
    def _apply(
        self, tool: str, arguments: dict[str, Any], change: SpecificationChange, apply_at_s: float | None
    ) -> dict[str, Any]:
        checked = _checked(change)
        if apply_at_s is None:
            before = self.slot.current
            new = self.slot.update(checked)
            logger.info("%s(%s): %s", tool, arguments, new.summary())
            return {
                "tool": tool,
                "arguments": arguments,
                "applied": True,
                "changed": new != before,
                "version": self.slot.version,
                "attached": attached_summary(new),
            }
        if not math.isfinite(apply_at_s):
            raise ToolCallError(f"apply_at_s must be a finite sim time, got {apply_at_s!r}")
        with self._pending_lock:
            # Dry run on the specification it will meet (current + earlier pending), so errors surface now.
            preview = checked(self._after_pending_locked())
            pending = PendingChange(float(apply_at_s), next(self._sequence), tool, arguments, checked)
            heapq.heappush(self._pending, (pending.apply_at_s, pending.sequence, pending))
        logger.info("%s(%s) scheduled at t=%.3f s", tool, arguments, apply_at_s)
        return {
            "tool": tool,
            "arguments": arguments,
            "applied": False,
            "apply_at_s": float(apply_at_s),
            "attached": attached_summary(preview),
        }

    def _after_pending_locked(self) -> Specification:
        spec = self.slot.current
        for _, _, pending in sorted(self._pending):
            spec = pending.change(spec)
        return spec

    def apply_due(self, now_s: float) -> list[PendingChange]:
        """Apply every queued change whose time has come, in time then call order. Call once per control step.

        A queued change that fails when applied (it cannot, after its dry run, unless the specification was
        replaced behind the tools' back) is logged and dropped: the car keeps its last valid specification.
        """
        applied: list[PendingChange] = []
        with self._pending_lock:
            while self._pending and self._pending[0][0] <= now_s + 1e-9:
                _, _, pending = heapq.heappop(self._pending)
                try:
                    new = self.slot.update(pending.change)
                except (ToolCallError, SpecificationError, ValidationError) as error:
                    logger.error(
                        "scheduled %s(%s) failed at t=%.3f s: %s", pending.tool, pending.arguments, now_s, error
                    )
                    continue
                logger.info("t=%.3f s: applied %s(%s): %s", now_s, pending.tool, pending.arguments, new.summary())
                applied.append(pending)
        if self._overtake is not None and self.situation_source is not None:
            done = self.advance_maneuvers()
            if done:
                logger.info("t=%.3f s: overtake %s", now_s, done)
        return applied

    def pending(self) -> list[dict[str, Any]]:
        with self._pending_lock:
            return [p.describe() for _, _, p in sorted(self._pending)]


def _checked(change: SpecificationChange) -> SpecificationChange:
    """Turn the specification's own refusals into ToolCallError, so callers see one error type."""

    def run(spec: Specification) -> Specification:
        try:
            return change(spec)
        except (SpecificationError, ValidationError) as error:
            raise ToolCallError(str(error)) from error

    return run
