"""J4, following distance: keep a wanted gap to the vehicle ahead in the ego's path (adaptive cruise control).

Not in the paper: LaMPilot-Bench's "set the following distance to 25 m" / "increase the gap by 10 m". J0's
time gap stays mandatory: this term asks for a particular gap, J0 only for at least a safe one (the tool that
attaches J4 lowers J0's time gap when the passenger asks for less, to a floor: ``mcp/maneuvers.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from pydantic import Field

from agentic_mpc.primitives.base import (
    FloatArray,
    FusedTerms,
    Leader,
    Primitive,
    Rollouts,
    StepContext,
    TrackingReference,
    per_stage,
)
from agentic_mpc.primitives.path_tracking import PreparedPathTracking


class FollowingDistance(Primitive):
    """J4 = weight * 1/2 * sum_{k=1..H} (t(k) . (p(k) - g(k)))^2, divided by H unless ``normalise_by_horizon`` is off.

    g(k) is where the ego's centre would be with the wanted gap w(k) to the nearest leader's rear bumper at
    stage k, along the leader's contact tangent t(k) (see :class:`~agentic_mpc.primitives.base.Leader`):
    g(k) = contact(k) - w(k) t(k). Only the along-path error counts, so J1 still holds the lane. The wanted gap
    moves from the gap now (at the first stage, where J0's time gap starts) towards ``gap_m`` at
    ``approach_mps`` (a gap 50 m too long closes in 25 s at 2 m/s, not with a lunge). With no leader the term
    costs nothing and J1's speed rules.
    """

    kind: ClassVar[str] = "following_distance"
    paper_symbol: ClassVar[str] = "J4"

    gap_m: float = Field(..., ge=2.0, le=200.0, description="wanted bumper-to-bumper gap to the leader, m")
    weight: float = Field(
        20.0, gt=0, description="per stage on the along-path error in m^2 (20: J1's speed pull moves the gap "
        "by about 0.3 m, J1's weight being 3)"
    )
    approach_mps: float = Field(2.0, gt=0, le=20.0, description="how fast the wanted gap moves to gap_m, m/s")
    normalise_by_horizon: bool = True

    def summary(self) -> str:
        return f"following_distance(gap_m={self.gap_m:g})"

    def prepare(self, context: StepContext) -> PreparedFollowingDistance | PreparedPathTracking:
        leader = nearest_leader(context.surroundings.leaders, context.state)
        if leader is None:
            return PreparedFollowingDistance()
        state_xy = np.asarray(context.state[:2], dtype=np.float64)
        gap_now_m = float(leader.tangents[0] @ (leader.contact_points[0] - state_xy))
        t_s = context.dt_s * np.arange(1, context.horizon + 1)
        reach_m = self.approach_mps * t_s
        wanted_m = gap_now_m + np.clip(self.gap_m - gap_now_m, -reach_m, reach_m)
        targets = leader.contact_points - wanted_m[:, None] * leader.tangents
        stage_weight = 0.5 * per_stage(self.weight, context.horizon, self.normalise_by_horizon)
        # the along-path part of J1's squared distance: J1's form with no cross-track weight
        return PreparedPathTracking(TrackingReference(targets, leader.tangents), stage_weight, lateral_weight=0.0)


def nearest_leader(leaders: tuple[Leader, ...], state: FloatArray) -> Leader | None:
    """The leader whose bumper is nearest now (J0 may list a car cutting in besides the one ahead)."""
    if not leaders:
        return None
    xy = np.asarray(state[:2], dtype=np.float64)
    return min(leaders, key=lambda leader: float(leader.tangents[0] @ (leader.contact_points[0] - xy)))


@dataclass(frozen=True, slots=True)
class PreparedFollowingDistance:
    """No leader: nothing to keep a gap to."""

    def cost(self, rollouts: Rollouts) -> FloatArray:
        return np.zeros(rollouts.samples)

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        return True
