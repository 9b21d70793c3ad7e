"""What a plain-Python world is made of (validated; imports nothing heavy, so scenario files check fast)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from agentic_mpc.frozen_config import FrozenConfig

LaneRole = Literal["center", "left", "right"]
ROLES: tuple[LaneRole, ...] = ("center", "left", "right")
class PlainRoad(FrozenConfig):
    """Three lanes along +x: "center" on y = 0, "left" at +lane_width_m, "right" at -lane_width_m."""

    lane_width_m: float = Field(3.5, gt=0)
    start_x_m: float = -100.0
    length_m: float = Field(20_000.0, gt=0)
    speed_limit_mps: float = Field(25.0, gt=0)
    lefthand: bool = False

    def lane_y_m(self, role: str) -> float:
        return {"center": 0.0, "left": self.lane_width_m, "right": -self.lane_width_m}[role]

    def lane_of(self, y_m: float) -> LaneRole:
        return min(ROLES, key=lambda role: abs(y_m - self.lane_y_m(role)))

    def index_of(self, role: str) -> int:
        """Lane index as SUMO counts them (0 = rightmost in right-hand traffic)."""
        order = ("left", "center", "right") if self.lefthand else ("right", "center", "left")
        return order.index(role)


class EgoPlacement(FrozenConfig):
    x_m: float = 0.0
    lane: LaneRole = "center"
    speed_mps: float = Field(15.0, ge=0, le=60)


class ScriptedVehicle(FrozenConfig):
    """Another road user: drives along ``lane`` at ``desired_speed_mps`` from ``appear_at_s`` on.
    ``x_m: null`` places it ``behind_ego_m`` behind the ego when it appears (an ambulance coming up behind)."""

    id: str = Field(..., min_length=1)
    lane: LaneRole
    x_m: float | None
    desired_speed_mps: float = Field(..., ge=0)
    type_id: str = "passenger"
    emergency: bool = False
    radius_m: float = Field(2.0, gt=0)
    appear_at_s: float = Field(0.0, ge=0)
    behind_ego_m: float = Field(120.0, ge=0)


class PlainObstacle(FrozenConfig):
    """A static circular obstacle."""

    id: str = Field(..., min_length=1)
    x_m: float
    y_m: float = 0.0
    radius_m: float = Field(2.0, gt=0)
    in_j2: bool = Field(True, description="add it to the initial specification's obstacle avoidance (J2)")


class PlainConfig(FrozenConfig):
    """The plain world of a run."""

    road: PlainRoad = PlainRoad()
    ego: EgoPlacement = EgoPlacement()
    vehicles: tuple[ScriptedVehicle, ...] = ()
    obstacles: tuple[PlainObstacle, ...] = ()
    road_edges: bool = Field(True, description="J0 sees the road's edges (false: the paper's Scenario 1 as printed)")
    goal_s_m: float | None = Field(None, description="along-road position of the goal (default: the road's end - 40 m)")

    @model_validator(mode="after")
    def _unique_ids(self) -> PlainConfig:
        ids = ["ego", *(v.id for v in self.vehicles), *(o.id for o in self.obstacles)]
        duplicates = sorted({i for i in ids if ids.count(i) > 1})
        if duplicates:
            raise ValueError(f"ids must be unique, duplicated: {duplicates}")
        return self
