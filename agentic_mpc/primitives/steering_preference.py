"""J3, preferred steering direction: a soft bias towards evading on one side.

Two forms, both in the paper's shape ``weight/(2H) * sum min(0, sign * e)^2`` with sign +1 for ``left``:

- ``form="paper"``: ``e`` is the steering input delta(k), exactly as printed. It penalises every steering
  action of the unwanted sign, including the steering back that every swerve needs, so it biases weakly
  (measured: the wanted side in 4-8 of 10 runs at weight 1).
- ``form="lateral"`` (default): ``e`` is the predicted lateral offset from the attached path tracking
  reference (positive to the left), or from the ego's current heading line when no path is tracked, plus a
  dead zone: ``min(0, sign * e_lat + dead_zone_m)``. It penalises only evading to the unwanted side, which
  is what "avoid obstacles from the right" means, and costs nothing while the car tracks its lane (without
  the dead zone, sampling noise on the penalised side is cut off and the car sits ~1 m off its lane). When
  the ego already is further to the unwanted side than the dead zone, the dead zone is measured from where
  it is: going further than that costs, coming back does not. See docs/cost-design.md for the measurements.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field

from agentic_mpc.primitives.base import (
    FloatArray,
    FusedTerms,
    Primitive,
    Rollouts,
    StepContext,
    TrackingReference,
)

Direction = Literal["left", "right"]


class PreferredSteeringDirection(Primitive):
    """J3: prefer evading to the ``direction`` side."""

    kind: ClassVar[str] = "preferred_steering_direction"
    paper_symbol: ClassVar[str] = "J3"

    direction: Direction
    form: Literal["lateral", "paper"] = "lateral"
    weight: float = Field(200.0, gt=0)
    dead_zone_m: float = Field(
        1.0, ge=0, description="lateral form: offsets up to this far on the unwanted side cost nothing"
    )

    def summary(self) -> str:
        return f"preferred_steering_direction(direction={self.direction})"

    @property
    def sign(self) -> float:
        return 1.0 if self.direction == "left" else -1.0

    def prepare(self, context: StepContext) -> PreparedCostJ3:
        stage_weight = 0.5 * self.weight / context.horizon
        if self.form == "paper":
            return PreparedSteeringSign(self.sign, stage_weight)
        reference = context.tracking_reference
        if reference is None:  # the heading line through the ego: a point on it and its direction
            x, y, phi = (float(v) for v in context.state[:3])
            h = context.horizon
            reference = TrackingReference(
                np.tile([x, y], (h, 1)), np.tile([np.cos(phi), np.sin(phi)], (h, 1))
            )
        # Beyond the dead zone on the unwanted side already (after a lane change to that side, say), the dead
        # zone is measured from where the ego is: J3 charges going further, never the way back, and leaves it
        # the same room to move as on its lane (docs/traffic.md: standing 3.5 m to the unwanted side cost 755
        # whatever the plan, and the car stood for 60 s).
        tx, ty = float(reference.tangents[0, 0]), float(reference.tangents[0, 1])
        rx, ry = float(reference.points[0, 0]), float(reference.points[0, 1])
        x_m, y_m = float(context.state[0]), float(context.state[1])
        unwanted_now = -self.sign * (tx * (y_m - ry) - ty * (x_m - rx))
        dead_zone = self.dead_zone_m if unwanted_now <= self.dead_zone_m else unwanted_now + self.dead_zone_m
        return PreparedLateralSide(self.sign, stage_weight, dead_zone, reference)


@dataclass(frozen=True, slots=True)
class PreparedSteeringSign:
    sign: float
    stage_weight: float

    def cost(self, r: Rollouts) -> FloatArray:
        return self.stage_weight * np.sum(np.minimum(0.0, self.sign * r.delta) ** 2, axis=0)

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        terms.steer_sign.append((self.sign, self.stage_weight))
        return True


@dataclass(frozen=True, slots=True)
class PreparedLateralSide:
    sign: float
    stage_weight: float
    dead_zone_m: float
    reference: TrackingReference

    def cost(self, r: Rollouts) -> FloatArray:
        ref, tan = self.reference.points, self.reference.tangents
        e_lat = tan[:, 0:1] * (r.y_m - ref[:, 1:2]) - tan[:, 1:2] * (r.x_m - ref[:, 0:1])
        return self.stage_weight * np.sum(np.minimum(0.0, self.sign * e_lat + self.dead_zone_m) ** 2, axis=0)

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        terms.lateral.append(
            (self.sign, self.stage_weight, self.dead_zone_m, self.reference.points, self.reference.tangents)
        )
        return True


PreparedCostJ3 = PreparedSteeringSign | PreparedLateralSide
