"""The primitive objectives (the pool) and the specification that attaches them."""

from agentic_mpc.primitives.base import (
    Blockage,
    LaneLines,
    Leader,
    MovingDisc,
    Primitive,
    Rollouts,
    StepContext,
    Surroundings,
    TrackingReference,
)
from agentic_mpc.primitives.following_distance import FollowingDistance
from agentic_mpc.primitives.mandatory import Mandatory
from agentic_mpc.primitives.obstacle_avoidance import Circle, ObstacleAvoidance
from agentic_mpc.primitives.path_tracking import PathTracking
from agentic_mpc.primitives.pool import POOL, describe_pool
from agentic_mpc.primitives.specification import Specification, SpecificationError, SpecificationSlot
from agentic_mpc.primitives.steering_preference import PreferredSteeringDirection

__all__ = [
    "POOL",
    "Blockage",
    "Circle",
    "FollowingDistance",
    "LaneLines",
    "Leader",
    "Mandatory",
    "MovingDisc",
    "ObstacleAvoidance",
    "PathTracking",
    "PreferredSteeringDirection",
    "Primitive",
    "Rollouts",
    "Specification",
    "SpecificationError",
    "SpecificationSlot",
    "StepContext",
    "Surroundings",
    "TrackingReference",
    "describe_pool",
]
