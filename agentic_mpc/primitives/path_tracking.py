"""J1, path tracking: follow a lane at a reference speed (the paper's reference points)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import Field, WithJsonSchema, field_validator

from agentic_mpc.geometry import LanePath, PathError
from agentic_mpc.primitives.base import (
    FloatArray,
    FusedTerms,
    Primitive,
    Rollouts,
    StepContext,
    TrackingReference,
    per_stage,
)


class PathTracking(Primitive):
    """J1 = weight * 1/2 * sum_{k=1..H} ||p(k) - p_ref(k)||^2, divided by H unless ``normalise_by_horizon`` is off.

    The reference points move along ``path`` from the point closest to the ego at ``v_ref_mps``: point k
    lies ``v_ref_mps * dt * k`` further along by arc length (``reference_accel_mps2=None``, the paper's
    form). By default the points instead start at the ego's speed and approach v_ref at
    ``reference_accel_mps2``: identical at steady speed, but a change of v_ref (stop in the left lane,
    resume) becomes a feasible ramp instead of a step. As printed in the paper (not normalised) the
    tracking term outweighs the obstacle term and the car drives through obstacles (see
    docs/cost-design.md); the default divides by H.
    """

    kind: ClassVar[str] = "path_tracking"
    paper_symbol: ClassVar[str] = "J1"

    path: Annotated[
        LanePath,
        WithJsonSchema(
            {
                "type": "array",
                "items": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2},
                "minItems": 2,
                "description": "lane centre line as (x_m, y_m) vertices",
            }
        ),
    ]
    lane: str = Field("center", min_length=1, description="label of the lane the path belongs to")
    v_ref_mps: float = Field(..., ge=0, le=100, description="reference speed along the path, m/s")
    reference_accel_mps2: float | None = Field(
        3.0,
        gt=0,
        description="reference points start at the ego's speed and reach v_ref at this rate; None: the paper's "
        "constant-speed points (which at v_ref = 0 demand an instant stop and make lane changes overshoot)",
    )
    reference_start_mps: float = Field(
        2.0,
        ge=0,
        le=100,
        description="the ramp starts at the ego's speed, but not below this (nor above v_ref): from a standstill a "
        "ramp from 0 pulls with about 12, and the car stood beside a blocked lane with the road ahead free",
    )
    weight: float = Field(3.0, gt=0, description="paper: 1 with normalise_by_horizon off")
    lateral_weight: float = Field(
        1.0,
        gt=0,
        le=1000,
        description="multiplies the cross-track part of the error (1: the paper's isotropic distance); larger "
        "keeps the lane when the ego cannot keep up with its reference (dense traffic)",
    )
    normalise_by_horizon: bool = True

    @field_validator("path", mode="before")
    @classmethod
    def _coerce_path(cls, value: Any) -> LanePath:
        if isinstance(value, LanePath):
            return value
        try:
            return LanePath(value)
        except (PathError, TypeError, ValueError) as error:
            raise ValueError(str(error)) from error

    def describe(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "symbol": self.paper_symbol,
            "lane": self.lane,
            "v_ref_mps": self.v_ref_mps,
            "reference_accel_mps2": self.reference_accel_mps2,
            "reference_start_mps": self.reference_start_mps,
            "weight": self.weight,
            "lateral_weight": self.lateral_weight,
            "normalise_by_horizon": self.normalise_by_horizon,
            "path_length_m": round(self.path.length_m, 3),
        }

    def summary(self) -> str:
        return f"path_tracking(lane={self.lane}, v_ref_mps={self.v_ref_mps:g})"

    def prepare(self, context: StepContext) -> PreparedPathTracking:
        from agentic_mpc.primitives.reference_kernel import reference_points  # compiled: load on first use

        x, y, _, v = (float(value) for value in context.state)
        cap = context.surroundings.reference_speed_cap_mps
        v_ref = self.v_ref_mps if cap is None else min(self.v_ref_mps, cap)
        v_start = max(v, min(v_ref, self.reference_start_mps))
        points, tangents = reference_points(
            self.path, x, y, v_start, v_ref, self.reference_accel_mps2, context.dt_s, context.horizon
        )
        shift = context.surroundings.reference_shift_m
        if shift:  # the lane beside, passing a blockage of this one: along the left normal (-t_y, t_x)
            points = points + shift * np.stack((-tangents[:, 1], tangents[:, 0]), axis=1)
        stage_weight = 0.5 * per_stage(self.weight, context.horizon, self.normalise_by_horizon)
        return PreparedPathTracking(TrackingReference(points, tangents), stage_weight, self.lateral_weight)


@dataclass(frozen=True, slots=True)
class PreparedPathTracking:
    reference: TrackingReference
    stage_weight: float
    lateral_weight: float = 1.0

    def cost(self, r: Rollouts) -> FloatArray:
        dx = r.x_m - self.reference.points[:, 0:1]
        dy = r.y_m - self.reference.points[:, 1:2]
        squared = dx * dx + dy * dy
        if self.lateral_weight != 1.0:  # |e|^2 + (lambda - 1) * (cross-track e)^2
            cross = self.reference.tangents[:, 0:1] * dy - self.reference.tangents[:, 1:2] * dx
            squared = squared + (self.lateral_weight - 1.0) * cross * cross
        return self.stage_weight * np.sum(squared, axis=0)

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        terms.track.append((self.reference.points, self.reference.tangents, self.stage_weight, self.lateral_weight))
        return True
