"""The one builder of a run's initial specification: the scenario's settings, resolved on the world's road."""

from __future__ import annotations

from typing import Any

from agentic_mpc.primitives import (
    Mandatory,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
)
from agentic_mpc.scenario.schema import SpecificationSettings
from agentic_mpc.world.base import World


def initial_specification(settings: SpecificationSettings, world: World) -> Specification:
    """J0 with the scenario's weights; J1 on the named lane of the ego's road; J2 over the world's obstacles
    marked for it; J3 if the scenario attaches it from the start."""
    primitives: list[Any] = []
    if settings.path_tracking is not None:
        tracking = settings.path_tracking
        role, path = world.lane(tracking.lane)
        options = tracking.model_dump(exclude={"lane", "paper_reference"}, exclude_none=True)
        if tracking.paper_reference:
            options["reference_accel_mps2"] = None
        primitives.append(PathTracking(path=path, lane=role, **options))
    circles = world.obstacle_circles(only_in_j2=True)
    if settings.obstacle_avoidance is not None and circles:
        primitives.append(ObstacleAvoidance(obstacles=circles, penalty=settings.obstacle_avoidance.penalty))
    if settings.preferred_steering_direction is not None:
        primitives.append(PreferredSteeringDirection.model_validate(settings.preferred_steering_direction))
    return Specification.of(*primitives, mandatory=Mandatory.model_validate(settings.mandatory))


def steering_template(settings: SpecificationSettings) -> PreferredSteeringDirection | None:
    """The parameters J3 is attached with when the agent asks for a side (the scenario's J3, if any)."""
    j3 = settings.preferred_steering_direction
    return PreferredSteeringDirection.model_validate(j3) if j3 else None
