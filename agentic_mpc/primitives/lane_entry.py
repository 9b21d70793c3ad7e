"""J0's lane-entry gap, the NumPy reference (the fused kernel computes the same in ``controller/kernels.py``).

A plan whose body goes deeper into the lane of a vehicle beside the ego than it is now (``LaneNeighbour``) keeps a
time gap to that vehicle at each such stage: ahead of it, its speed x T + d0 from its front bumper (it follows the
ego in); behind it, the ego's speed x T + d0 to its rear (the ego follows it). The shortfall costs like J0's time
gap (squared up to a knee, linear beyond), in full once the body is ``LANE_ENTRY_RAMP_M`` deeper in than now.

Why: J0's discs keep the bodies apart at the predicted positions, which assume constant speeds. Merging 0.5 m in
front of a truck alongside, or swerving in 8 m behind a car that then brakes, is clear of the discs and ends in a
contact at fault when the other accelerates or brakes (docs/traffic.md, "Gap acceptance when entering a lane").
Measured from the depth now, so a car already partly in a lane is not pushed by it, and a little further each step
costs almost the full price at once (a short ramp).
"""

from __future__ import annotations

import numpy as np

from agentic_mpc.primitives.base import FloatArray, LaneNeighbour, Rollouts

LANE_ENTRY_RAMP_M = 0.1
"""The lane-entry gap is charged in full once the body is this much deeper in the neighbour's lane than now."""


def lane_entry_params(neighbour: LaneNeighbour, time_gap_s: float, standstill_gap_m: float, weight_per_stage: float,
                      knee_m: float) -> tuple[float, ...]:
    """The fused kernel's 9 parameters of one neighbour (``FusedArrays.neighbour_params``)."""
    return (neighbour.lane_reach_m, neighbour.contact_m, neighbour.speed_mps,
            neighbour.entry_depth_now_m, time_gap_s, standstill_gap_m, weight_per_stage, knee_m,
            1.0 / LANE_ENTRY_RAMP_M)


def lane_entry_cost(neighbour: LaneNeighbour, r: Rollouts, time_gap_s: float, standstill_gap_m: float,
                    weight_per_stage: float, knee_m: float) -> FloatArray:
    """(S,) the lane-entry gap's cost of every sample for one neighbour, summed over the stages."""
    cx, cy = neighbour.centres[:, 0:1], neighbour.centres[:, 1:2]
    tx, ty = neighbour.tangents[:, 0:1], neighbour.tangents[:, 1:2]
    lx, ly = neighbour.lane_points[:, 0:1], neighbour.lane_points[:, 1:2]
    nx, ny = neighbour.lane_tangents[:, 0:1], neighbour.lane_tangents[:, 1:2]
    lateral = nx * (r.y_m - ly) - ny * (r.x_m - lx)
    entered = neighbour.lane_reach_m - np.abs(lateral) - neighbour.entry_depth_now_m
    along = tx * (r.x_m - cx) + ty * (r.y_m - cy)
    ahead = np.maximum(0.0, neighbour.speed_mps * time_gap_s + standstill_gap_m - (along - neighbour.contact_m))
    behind = np.maximum(0.0, r.v_mps * time_gap_s + standstill_gap_m - (-along - neighbour.contact_m))
    shortfall = np.where(along >= 0.0, ahead, behind)
    huber = np.where(shortfall > knee_m, knee_m * (2.0 * shortfall - knee_m), shortfall**2)
    share = np.where(entered > 0.0, np.minimum(1.0, entered / LANE_ENTRY_RAMP_M), 0.0)
    return weight_per_stage * np.sum(share * huber, axis=0)
