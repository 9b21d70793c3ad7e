"""J2, obstacle avoidance: a penalty for every predicted step inside a circular region."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.primitives.base import (
    STANDING_PLAN_MPS,
    FloatArray,
    FusedTerms,
    Primitive,
    Rollouts,
    StepContext,
    per_stage,
)


class Circle(FrozenConfig):
    """A circular region to keep the ego's centre out of."""


    x_m: float
    y_m: float
    radius_m: float = Field(..., gt=0)
    label: str = ""


STANDING_RIM_M = 0.5
"""A moving car's plan that ends standing less than this outside a circle's rim (or inside it) pays: from a stand on
the rim, every way forward that the model can steer clips the circle, and J2 charges each stage inside (seed 2516 of
``incident_in_traffic`` stood 99 s beside a stopped car's front with its centre on the rim: docs/traffic.md)."""
STANDING_RIM_WEIGHT = 50.0
"""On (how far the plan's end is inside rim + STANDING_RIM_M, at most STANDING_RIM_M)^2 x (1 - v / the standing
speed)."""


class ObstacleAvoidance(Primitive):
    """J2 = weight * 100/H * sum_{k=1..H} I(p(k) inside any circle) (the paper's form, weight 1), and, while the car
    moves, a terminal cost on a plan that ends standing on a circle's rim (:data:`STANDING_RIM_M`)."""

    kind: ClassVar[str] = "obstacle_avoidance"
    paper_symbol: ClassVar[str] = "J2"

    obstacles: tuple[Circle, ...] = Field(..., min_length=1)
    penalty: float = Field(100.0, gt=0, description="cost of the whole horizon inside (paper: 100)")
    weight: float = Field(1.0, gt=0)

    def describe(self) -> dict[str, Any]:
        return {"kind": self.kind, "symbol": self.paper_symbol, **self.model_dump(mode="json")}

    def summary(self) -> str:
        return f"obstacle_avoidance(n={len(self.obstacles)})"

    def prepare(self, context: StepContext) -> PreparedObstacleAvoidance:
        stage = self.weight * per_stage(self.penalty, context.horizon, True)
        table = np.array([[c.x_m, c.y_m, c.radius_m**2, stage] for c in self.obstacles], dtype=np.float64)
        if float(context.state[3]) < STANDING_PLAN_MPS:
            return PreparedObstacleAvoidance(table)
        rims = np.array([[c.x_m, c.y_m, c.radius_m + STANDING_RIM_M, STANDING_RIM_M, self.weight * STANDING_RIM_WEIGHT,
                          STANDING_PLAN_MPS] for c in self.obstacles], dtype=np.float64)
        return PreparedObstacleAvoidance(table, rims)


@dataclass(frozen=True, slots=True)
class PreparedObstacleAvoidance:
    circles: FloatArray  # (n, 4): cx, cy, r^2, stage weight
    rims: FloatArray | None = None  # (n, 6): cx, cy, outer radius, rim depth, weight, standing speed; None: standing

    def cost(self, r: Rollouts) -> FloatArray:
        total = np.zeros(r.samples)
        for cx, cy, r2, stage_weight in self.circles:
            inside = (r.x_m - cx) ** 2 + (r.y_m - cy) ** 2 < r2
            total += stage_weight * np.count_nonzero(inside, axis=0)
        x, y, v = r.x_m[-1], r.y_m[-1], r.v_mps[-1]  # the rims: on the last state, as the fused kernel writes it
        for cx, cy, outer, depth, weight, standing in () if self.rims is None else self.rims:
            within = np.maximum(0.0, np.minimum(outer - np.sqrt((x - cx) ** 2 + (y - cy) ** 2), depth))
            total += np.where(v < standing, weight * (1.0 - v / standing) * within * within, 0.0)
        return total

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        terms.circles.extend(tuple(row) for row in self.circles)
        if self.rims is not None:
            terms.rims.extend(tuple(row) for row in self.rims)
        return True
