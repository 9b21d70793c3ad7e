"""The manoeuvre tools: lanes relative to the ego's (or by index), relative speeds, a following distance,
overtaking and pulling over (LaMPilot-Bench's commands; :mod:`agentic_mpc.mcp.tools` has the paper's).

They read the ego's :class:`~agentic_mpc.world.lanes.Situation` (its lane, speed, leader) from the tools'
situation source, and refuse what the scene cannot do with the reason (no lane to that side, no emergency
lane, no leader), so that the car keeps its specification. An overtake is a manoeuvre over time: the tool
starts it (J1 on the passing lane at the road's limit) and :meth:`ManeuverTools.advance_maneuvers`, called by
``apply_due`` every control step, ends it once the ego is clear ahead of the car it passed (then J1 keeps
that lane or returns to the one it came from, as asked, at the speed it had).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError

from agentic_mpc.geometry import LanePath
from agentic_mpc.mcp.protocol import ToolName
from agentic_mpc.mcp.tool_table import Side, ToolCallError, tool
from agentic_mpc.primitives import FollowingDistance, Mandatory, PathTracking, Specification
from agentic_mpc.world.lanes import RoadLanes

FOLLOWING = FollowingDistance.kind
MIN_TIME_GAP_S = 0.4
"""The shortest time gap J0 is lowered to when the passenger asks for a close following distance."""
OVERTAKE_CLEAR_LENGTHS = 2.0
"""An overtake ends this many ego lengths (centre to centre), plus a second at the speed difference, past
the car it passes (LaMPilot counts an overtake done at two car lengths)."""

LaneIndex = Annotated[int, Field(ge=0, le=15, description="the lane's index as sumo://road lists it (0: the edge lane)")]
SpeedChangeMps = Annotated[float, Field(ge=-60.0, le=60.0, description="change of the reference speed, m/s "
                                                                       "(negative: slower); capped at the road's limit")]
GapM = Annotated[float, Field(ge=2.0, le=200.0, description="wanted gap to the car ahead, m (bumper to bumper)")]
GapChangeM = Annotated[float, Field(ge=-200.0, le=200.0, description="change of the gap now, m (negative: closer)")]
Afterwards = Annotated[Literal["keep", "return"], Field(description="after passing: keep the passing lane, or "
                                                                    "return to the lane the car came from")]


@dataclass
class Overtake:
    """An overtake in progress."""

    leader_id: str
    from_lane: str
    to_lane: str
    afterwards: str
    v_ref_mps: float


class ManeuverTools:
    """Mixed into :class:`~agentic_mpc.mcp.tools.ControllerTools`, which gives ``slot``, ``road()``,
    ``situation()``, ``set_reference_speed`` and ``_apply``."""

    _overtake: Overtake | None = None

    # ------------------------------------------------------------------ tools (docstrings: what a model reads)
    @tool(ToolName.CHANGE_LANE)
    def change_lane(self, direction: Side, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Change to the next lane on the given side ('left' or 'right') of the lane the car is in now, at
        the same reference speed: attaches the path tracking objective (J1) on that lane."""
        road, here = self._road_and_lane()
        target = road.neighbour(here, direction)
        if target is None or target == road.shoulder_index:
            what = "the emergency lane (use pull_over to stop there)" if target is not None else "no lane"
            raise ToolCallError(f"there is {what} to the {direction} of the car's lane {road.label(here)}")
        return self._drive_on(ToolName.CHANGE_LANE, {"direction": direction}, road, target, None, apply_at_s)

    @tool(ToolName.KEEP_LANE)
    def keep_lane(self, index: LaneIndex, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Drive in the lane with this index (sumo://road lists the lanes and their indices), at the same
        reference speed."""
        road = self._road_with_indices()
        if not 0 <= index < len(road.by_index):
            raise ToolCallError(f"lane index {index} is not on this road (indices 0-{len(road.by_index) - 1})")
        if index == road.shoulder_index:
            raise ToolCallError(f"lane {index} is the emergency lane: use pull_over to stop there")
        return self._drive_on(ToolName.KEEP_LANE, {"index": index}, road, index, None, apply_at_s)

    @tool(ToolName.CHANGE_REFERENCE_SPEED)
    def change_reference_speed(self, delta_v: SpeedChangeMps, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Change the reference speed by delta_v m/s from the car's speed now (positive: faster), keeping the
        lane; the result is capped to [0, the road's speed limit] and the answer says when it was."""
        if isinstance(delta_v, bool) or not isinstance(delta_v, int | float) or not math.isfinite(delta_v):
            raise ToolCallError(f"delta_v must be a finite number in m/s, got {delta_v!r}")
        road, situation = self.road(), self.situation()
        wanted = situation.speed_mps + float(delta_v)
        v = min(max(wanted, 0.0), road.speed_limit_mps)
        result = self.set_reference_speed(round(v, 3), apply_at_s=apply_at_s)
        result.update(tool=str(ToolName.CHANGE_REFERENCE_SPEED), arguments={"delta_v": float(delta_v)},
                      v_ref_mps=round(v, 3))
        if v != wanted:
            result["capped"] = (f"{wanted:.2f} m/s is outside [0, {road.speed_limit_mps:g}] m/s (the road's limit): "
                                f"set to {v:.2f} m/s")
        return result

    @tool(ToolName.SET_FOLLOWING_DISTANCE)
    def set_following_distance(self, gap: GapM, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Keep a following distance of gap metres (bumper to bumper) to the car ahead in this lane: attaches
        the following distance objective (J4); for a gap closer than the safe time gap, J0's time gap is
        lowered to match, not below 0.4 s."""
        return self._follow(ToolName.SET_FOLLOWING_DISTANCE, {"gap": gap}, lambda gap_now: float(gap), apply_at_s)

    @tool(ToolName.CHANGE_FOLLOWING_DISTANCE)
    def change_following_distance(self, change: GapChangeM, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Change the following distance to the car ahead in this lane by change metres from the gap now
        (negative: closer), as set_following_distance does."""
        return self._follow(ToolName.CHANGE_FOLLOWING_DISTANCE, {"change": change},
                            lambda gap_now: gap_now + float(change), apply_at_s)

    def _follow(self, name: str, arguments: dict[str, Any], wanted_of: Any, apply_at_s: float | None) -> dict[str, Any]:
        situation = self.situation()
        if situation.leader_gap_m is None:
            raise ToolCallError("there is no car ahead in the car's lane within 100 m to keep a distance to")
        wanted = wanted_of(situation.leader_gap_m)
        if not 2.0 <= wanted <= 200.0:
            raise ToolCallError(f"a following distance of {wanted:.1f} m is outside [2, 200] m "
                                f"(the gap now is {situation.leader_gap_m:.1f} m)")
        leader_speed = max(situation.leader_speed_mps or 0.0, 1.0)

        def change_spec(spec: Specification) -> Specification:
            j4 = spec.get(FOLLOWING)
            fields = j4.model_dump() if isinstance(j4, FollowingDistance) else {}
            new = spec.attach(validated(FollowingDistance, {**fields, "gap_m": wanted}))
            j0 = new.mandatory
            wanted_time_gap_s = max(MIN_TIME_GAP_S, (0.8 * wanted - j0.standstill_gap_m) / leader_speed)
            if wanted_time_gap_s < j0.time_gap_s:
                new = new.attach(validated(Mandatory, {**j0.model_dump(), "time_gap_s": round(wanted_time_gap_s, 3)}))
            return new

        result = self._apply(name, {key: float(value) for key, value in arguments.items()}, change_spec, apply_at_s)
        result["gap_m"] = round(wanted, 2)
        return result

    @tool(ToolName.CLEAR_FOLLOWING_DISTANCE)
    def clear_following_distance(self, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Remove the following distance objective (J4): the car drives at its reference speed, keeping J0's
        safe gap (its time gap back to the initial specification's if a close gap had lowered it)."""
        initial_time_gap_s = self.slot.initial.mandatory.time_gap_s

        def change(spec: Specification) -> Specification:
            spec = spec.detach(FOLLOWING) if FOLLOWING in spec else spec
            j0 = spec.mandatory
            if j0.time_gap_s < initial_time_gap_s:
                spec = spec.attach(validated(Mandatory, {**j0.model_dump(), "time_gap_s": initial_time_gap_s}))
            return spec

        return self._apply(ToolName.CLEAR_FOLLOWING_DISTANCE, {}, change, apply_at_s)

    @tool(ToolName.OVERTAKE)
    def overtake(self, side: Side, afterwards: Afterwards = "keep", *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Overtake the car ahead in this lane using the lane on the given side, at the road's speed limit;
        once clear ahead of it, keep that lane or return to this one ('keep' or 'return'), at the speed the
        car had."""
        road, here = self._road_and_lane()
        situation = self.situation()
        if situation.leader_id is None:
            raise ToolCallError("there is no car ahead in the car's lane within 100 m to overtake")
        target = road.neighbour(here, side)
        if target is None or target == road.shoulder_index:
            raise ToolCallError(f"there is no lane to overtake in on the {side} of lane {road.label(here)}")
        current = self.slot.current.get(PathTracking.kind)
        v_before = current.v_ref_mps if isinstance(current, PathTracking) else situation.speed_mps
        result = self._drive_on(ToolName.OVERTAKE, {"side": side, "afterwards": afterwards}, road, target,
                                road.speed_limit_mps, apply_at_s)
        self._overtake = Overtake(situation.leader_id, road.label(here), road.label(target), afterwards, v_before)
        result["passing"] = situation.leader_id
        return result

    @tool(ToolName.PULL_OVER, available=lambda tools: tools.road().shoulder_index is not None)
    def pull_over(self, *, apply_at_s: float | None = None) -> dict[str, Any]:
        """Pull over onto the emergency lane (the hard shoulder) and stop there."""
        road = self._road_with_indices()
        if road.shoulder_index is None:
            raise ToolCallError("this road has no emergency lane to pull over onto")
        self._overtake = None
        return self._drive_on(ToolName.PULL_OVER, {}, road, road.shoulder_index, 0.0, apply_at_s)

    # ------------------------------------------------------------------ the overtake over time
    def advance_maneuvers(self) -> str | None:
        """End an overtake whose car is passed (or gone from view); returns what was done, or None."""
        overtake = self._overtake
        if overtake is None:
            return None
        tracking = self.slot.current.get(PathTracking.kind)
        if not isinstance(tracking, PathTracking) or tracking.lane != overtake.to_lane:
            self._overtake = None  # another tool changed the lane since: the overtake is over
            return None
        situation = self.situation()
        passed = situation.positions.get(overtake.leader_id)
        if passed is not None:
            lead_m = situation.road_s_m - passed[0]
            if lead_m < OVERTAKE_CLEAR_LENGTHS * situation.length_m + max(0.0, situation.speed_mps - 20.0):
                return None
        self._overtake = None
        road = self.road()
        lane = overtake.from_lane if overtake.afterwards == "return" else overtake.to_lane
        path = road.lanes.get(lane) or next((p for i, p in enumerate(road.by_index) if road.label(i) == lane), None)
        if path is None:
            return None
        v = min(overtake.v_ref_mps, road.speed_limit_mps)
        self.slot.update(lambda spec: spec.attach(path_tracking_like(spec, path=path, lane=lane, v_ref_mps=v)))
        return f"passed {overtake.leader_id}: {'back to' if overtake.afterwards == 'return' else 'keeping'} lane {lane}"

    # ------------------------------------------------------------------ helpers
    def _road_with_indices(self) -> RoadLanes:
        road = self.road()
        if not road.by_index or not road.left_to_right:
            raise ToolCallError("this world does not number its lanes")
        return road

    def _road_and_lane(self) -> tuple[RoadLanes, int]:
        road = self._road_with_indices()
        here = self.situation().lane_index
        if here is None or not 0 <= here < len(road.by_index):
            raise ToolCallError("the car is not on a lane of its road")
        return road, here

    def _drive_on(self, name: str, arguments: dict[str, Any], road: RoadLanes, index: int, v_ref_mps: float | None,
                  apply_at_s: float | None) -> dict[str, Any]:
        lane, path = road.label(index), road.by_index[index]

        def change(spec: Specification) -> Specification:
            current = spec.get(PathTracking.kind)
            v = v_ref_mps if v_ref_mps is not None else (
                current.v_ref_mps if isinstance(current, PathTracking) else self.situation().speed_mps)
            return spec.attach(path_tracking_like(spec, path=path, lane=lane, v_ref_mps=min(v, road.speed_limit_mps)))

        if name != ToolName.OVERTAKE:
            self._overtake = None
        result = self._apply(name, arguments, change, apply_at_s)
        result["lane"] = lane
        return result



def validated(model: type, fields: dict[str, Any]) -> Any:
    try:
        return model.model_validate(fields)
    except ValidationError as error:
        raise ToolCallError(f"invalid {model.__name__}: {error.errors(include_url=False)}") from error


def path_tracking_like(spec: Specification, *, path: LanePath, lane: str, v_ref_mps: float) -> PathTracking:
    """A new J1 with the weights of the attached (or initial) one, on ``path`` at ``v_ref_mps``."""
    current = spec.get(PathTracking.kind)
    fields = current.model_dump() if isinstance(current, PathTracking) else {}
    fields.update(path=path, lane=lane, v_ref_mps=v_ref_mps)
    return validated(PathTracking, fields)
