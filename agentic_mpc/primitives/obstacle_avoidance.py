"""J2, obstacle avoidance: a penalty for every predicted step inside a circular region."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.primitives.base import FloatArray, FusedTerms, Primitive, Rollouts, StepContext, per_stage


class Circle(FrozenConfig):
    """A circular region to keep the ego's centre out of."""


    x_m: float
    y_m: float
    radius_m: float = Field(..., gt=0)
    label: str = ""


class ObstacleAvoidance(Primitive):
    """J2 = weight * 100/H * sum_{k=1..H} I(p(k) inside any circle) (the paper's form, weight 1)."""

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
        return PreparedObstacleAvoidance(table)


@dataclass(frozen=True, slots=True)
class PreparedObstacleAvoidance:
    circles: FloatArray  # (n, 4): cx, cy, r^2, stage weight

    def cost(self, r: Rollouts) -> FloatArray:
        total = np.zeros(r.samples)
        for cx, cy, r2, stage_weight in self.circles:
            inside = (r.x_m - cx) ** 2 + (r.y_m - cy) ** 2 < r2
            total += stage_weight * np.count_nonzero(inside, axis=0)
        return total

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        terms.circles.extend(tuple(row) for row in self.circles)
        return True
