"""The pool: every primitive family the controller knows, by kind."""

from __future__ import annotations

from typing import Any

from agentic_mpc.primitives.base import Primitive
from agentic_mpc.primitives.following_distance import FollowingDistance
from agentic_mpc.primitives.mandatory import Mandatory
from agentic_mpc.primitives.obstacle_avoidance import ObstacleAvoidance
from agentic_mpc.primitives.path_tracking import PathTracking
from agentic_mpc.primitives.steering_preference import PreferredSteeringDirection

POOL: dict[str, type[Primitive]] = {
    cls.kind: cls for cls in (Mandatory, PathTracking, ObstacleAvoidance, PreferredSteeringDirection, FollowingDistance)
}


def describe_pool() -> list[dict[str, Any]]:
    """Each family with its symbol, whether it is mandatory, its documentation and its parameter schema."""
    described = []
    for kind, cls in POOL.items():
        schema = cls.model_json_schema()
        schema.pop("title", None)
        described.append(
            {
                "kind": kind,
                "symbol": cls.paper_symbol,
                "mandatory": cls.mandatory,
                "doc": (cls.__doc__ or "").strip().splitlines()[0],
                "parameters": schema.get("properties", {}),
            }
        )
    return described
