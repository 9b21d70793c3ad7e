"""The contract between the MCP server (:mod:`agentic_mpc.mcp.server`) and its clients (our agent, any host).

A client that knows this module needs nothing of the server's implementation:

- the resource URIs the server registers, all JSON: the observation resources (:data:`EGO_URI`,
  :data:`TRAFFIC_URI`, :data:`EMERGENCY_VEHICLES_URI`, :data:`OBSTACLES_URI`, together
  :data:`OBSERVATION_URIS`), one road user by id (:data:`VEHICLE_URI_TEMPLATE`), the road (:data:`ROAD_URI`:
  lanes, handedness, edge lane, speed limit, what yielding and resuming mean), the specification attached
  now (:data:`SPECIFICATION_URI`), the one the car started with (:data:`INITIAL_SPECIFICATION_URI`) and the
  primitive pool (:data:`POOL_URI`);
- the tools' names (:class:`ToolName`, :func:`lane_tool_name`) and argument names: the server registers
  its tools under these, and a client that calls one by name (the rules backend, the eval suite) says it
  through them, never as a string of its own;
- :data:`APPLY_AT_META_KEY`, the ``tools/call`` request ``_meta`` key that schedules a change at a sim time;
- :func:`validate_arguments`, the check the server applies to every tool call against the tool's published
  input schema (a client may run it first to answer a bad call without a round trip).

It imports neither the MCP SDK nor anything of the tools.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Any


class ToolName(StrEnum):
    """The tools that are not per lane (a member is its name as a ``str``)."""

    SET_REFERENCE_SPEED = "set_reference_speed"
    SET_PREFERRED_STEERING_DIRECTION = "set_preferred_steering_direction"
    CLEAR_PREFERRED_STEERING_DIRECTION = "clear_preferred_steering_direction"
    CHANGE_LANE = "change_lane"
    KEEP_LANE = "keep_lane"
    CHANGE_REFERENCE_SPEED = "change_reference_speed"
    SET_FOLLOWING_DISTANCE = "set_following_distance"
    CHANGE_FOLLOWING_DISTANCE = "change_following_distance"
    CLEAR_FOLLOWING_DISTANCE = "clear_following_distance"
    OVERTAKE = "overtake"
    PULL_OVER = "pull_over"
    TURN_AT_NEXT_JUNCTION = "turn_at_next_junction"
    DRIVE_TO = "drive_to"


def lane_tool_name(lane: str) -> str:
    """The tool that drives on the ego road's lane ``lane`` (the paper's ``run_center_lane``, ...): one per
    lane label the road has (:data:`ROAD_URI` lists them)."""
    return f"run_{lane}_lane"


def lane_of_tool(name: str) -> str | None:
    """The lane label of a lane tool's name, or None for any other tool."""
    if name.startswith("run_") and name.endswith("_lane") and len(name) > len("run__lane"):
        return name[len("run_"):-len("_lane")]
    return None


def is_tool_name(name: str) -> bool:
    """Whether ``name`` is one of the server's tool names (a lane tool for any lane label)."""
    return name in ToolName.__members__.values() or lane_of_tool(name) is not None


SPEED_ARGUMENT = "v_ref"
"""The argument in m/s of the lane tools and ``set_reference_speed``, from 0 to the road's speed limit."""
DIRECTION_ARGUMENT = "direction"
"""The argument (``left`` or ``right``) of ``set_preferred_steering_direction``."""

APPLY_AT_META_KEY = "agentic-mpc/apply_at_s"
"""Request ``_meta`` key: apply the tool call's change at this sim time (lockstep)."""

EGO_URI = "sumo://ego"
"""The ego vehicle: position, heading, speed, lane; and the collisions so far."""
TRAFFIC_URI = "sumo://traffic"
"""Every other road user near the ego."""
EMERGENCY_VEHICLES_URI = "sumo://emergency-vehicles"
"""Emergency vehicles near the ego."""
OBSTACLES_URI = "sumo://obstacles"
"""Static obstacles on the road."""
OBSERVATION_URIS = (EGO_URI, TRAFFIC_URI, EMERGENCY_VEHICLES_URI, OBSTACLES_URI)
"""The resources read from the world's latest observation; updated as the simulation advances."""
VEHICLE_URI_TEMPLATE = "sumo://vehicle/{vehicle_id}"
"""One road user by id (the ego is ``ego``)."""
ROUTE_URI = "sumo://route"
"""Where a world with junctions has the ego going: the route's edges, where on it the ego is, the next junction
where the road divides (its distance, the directions it offers, where the route goes, the light) and the
junctions ahead (:mod:`agentic_mpc.world.routes`)."""
ROAD_URI = "sumo://road"
"""The ego's road: its lanes (``left``/``center``/``right`` as the tools name them, SUMO index, role),
``traffic`` (``left-hand`` or ``right-hand``), ``edge_lane`` (where to pull over to yield), ``speed_limit_mps``,
and one plain-English sentence each on what ``yield`` and ``resume`` mean there (see mcp/road.py); the scenario's
``jurisdiction`` and ``road_type`` where it names them."""

SPECIFICATION_URI = "mpc://specification"
"""The specification attached now, its version and the pending scheduled changes."""
INITIAL_SPECIFICATION_URI = "mpc://specification/initial"
"""The specification the car started with."""
POOL_URI = "mpc://pool"
"""Every primitive objective family and its parameters."""
TACTICS_URI = "mpc://tactics"
"""The driving tactics in force (rules by name) and the one changing J1's reference now, if any: the lane it
follows instead of the tracked one, past which obstacle, since when (``agentic_mpc/tactics``)."""
MEMORY_URI = "agent://memory"
"""The embedded agent's memory of its passenger profile (``agent: {memory: ...}``, agent/memory.py): the file, the
standing preferences and every entry; ``{"profile": null}`` without memory."""


def _non_finite(value: Any, path: str = "") -> str | None:
    """The path of the first non-finite float in ``value`` (nested dicts and lists), or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return path or "(value)"
    if isinstance(value, dict):
        for key, item in value.items():
            if (found := _non_finite(item, f"{path}.{key}" if path else str(key))) is not None:
                return found
    if isinstance(value, list):
        for index, item in enumerate(value):
            if (found := _non_finite(item, f"{path}[{index}]")) is not None:
                return found
    return None


def validate_arguments(tool_name: str, schema: dict[str, Any], arguments: Any) -> None:
    """Raise ``ValueError`` with a readable message if ``arguments`` break ``schema`` or are not finite."""
    import jsonschema  # deferred: slow to import, and only needed once a call is checked

    if not isinstance(arguments, dict):
        raise ValueError(  # noqa: TRY004 - callers catch one error type for every bad call
            f"arguments of {tool_name} must be a JSON object, got {type(arguments).__name__}"
        )
    if (where := _non_finite(arguments)) is not None:
        raise ValueError(f"invalid arguments for {tool_name}: {where} is not a finite number")
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(arguments), key=lambda e: list(e.path))
    if errors:
        details = "; ".join(f"{'.'.join(map(str, e.path)) or 'arguments'}: {e.message}" for e in errors)
        raise ValueError(f"invalid arguments for {tool_name}: {details}")
