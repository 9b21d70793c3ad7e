"""The MCP resources of the simulation's server (JSON): what SUMO sees and what the controller is asked.

``sumo://ego``, ``sumo://traffic``, ``sumo://emergency-vehicles``, ``sumo://obstacles`` are slices of the
world's latest observation; ``sumo://vehicle/{vehicle_id}`` is one road user by id; ``sumo://road`` the
road (:mod:`agentic_mpc.mcp.road`); ``mpc://specification``, ``mpc://specification/initial`` and
``mpc://pool`` the controller's side; ``sumo://route`` where a world with junctions has the ego going;
``agent://memory`` the embedded agent's memory of its passenger.
"""

# No `from __future__ import annotations`: the SDK reads the resource functions' annotations at runtime.
import json
import math
from collections.abc import Callable
from typing import Any

from mcp.server.mcpserver import MCPServer
from mcp.server.mcpserver.exceptions import ResourceNotFoundError

from agentic_mpc.mcp.protocol import (
    EGO_URI,
    EMERGENCY_VEHICLES_URI,
    INITIAL_SPECIFICATION_URI,
    MEMORY_URI,
    OBSTACLES_URI,
    POOL_URI,
    ROAD_URI,
    ROUTE_URI,
    SPECIFICATION_URI,
    TACTICS_URI,
    TRAFFIC_URI,
    VEHICLE_URI_TEMPLATE,
)
from agentic_mpc.mcp.road import LaneIndex, describe_road
from agentic_mpc.mcp.tools import ControllerTools
from agentic_mpc.primitives import Specification
from agentic_mpc.primitives.pool import describe_pool

ObservationSource = Callable[[], dict[str, Any]]

OBSERVATION_SLICES = (
    # uri, name, description, {key in the resource: key in the observation}
    (EGO_URI, "ego", "The ego vehicle: position, heading, speed, lane.", {"ego": "ego", "collisions": "collisions"}),
    (TRAFFIC_URI, "traffic", "Every other road user near the ego.", {"vehicles": "traffic"}),
    (EMERGENCY_VEHICLES_URI, "emergency-vehicles",
     ("Emergency vehicles (ambulances, fire engines, police) near the ego, and the run's events so far (one "
      "approaching from behind, passed)."), {"emergency_vehicles": "emergency_vehicles", "events": "emergency_events"}),
    (OBSTACLES_URI, "obstacles", "Static obstacles on the road.", {"obstacles": "obstacles"}),
)
_LISTS = {"traffic", "emergency_vehicles", "emergency_events", "obstacles", "collisions"}
"""Observation keys that are lists: an observation without them reads as empty, not null."""


def register_resources(server: MCPServer, tools: ControllerTools, latest_observation: ObservationSource,
                       lane_index: LaneIndex | None = None, jurisdiction: str | None = None,
                       road_type: str | None = None, tactics: Callable[[], dict[str, Any]] | None = None,
                       memory: Callable[[], dict[str, Any] | None] | None = None,
                       route: Callable[[], dict[str, Any]] | None = None) -> None:
    """Register every resource on ``server``."""
    slot = tools.slot
    for uri, name, description, keys in OBSERVATION_SLICES:
        server.resource(uri, name=name, description=description, mime_type="application/json")(
            _observation_slice(latest_observation, keys)
        )

    @server.resource(VEHICLE_URI_TEMPLATE, name="vehicle",
                     description="One road user by id (the ego is 'ego').", mime_type="application/json")
    def vehicle(vehicle_id: str) -> str:
        obs = latest_observation()
        candidates = [obs.get("ego") or {}, *obs.get("traffic", []), *obs.get("emergency_vehicles", [])]
        for candidate in candidates:
            if str(candidate.get("id")) == vehicle_id:
                return to_json({"time_s": obs.get("time_s"), "vehicle": candidate})
        known = sorted({str(c.get("id")) for c in candidates if c.get("id") is not None})
        raise ResourceNotFoundError(f"no road user {vehicle_id!r} in the simulation now (known: {known})")

    @server.resource(ROAD_URI, name="road", description="The road: lanes (as the tools name them), handedness, "
                     "edge lane, speed limit, what yielding and resuming mean.", mime_type="application/json")
    def road() -> str:
        tracking = slot.initial.get("path_tracking")
        described = describe_road(tools.road(), getattr(tracking, "lane", None),
                                  getattr(tracking, "v_ref_mps", None), lane_index)
        rules = {key: value for key, value in (("jurisdiction", jurisdiction), ("road_type", road_type)) if value}
        return to_json({**described, **rules})

    @server.resource(SPECIFICATION_URI, name="specification",
                     description="The control specification attached now, its version and pending changes.",
                     mime_type="application/json")
    def specification() -> str:
        spec, version = slot.snapshot()
        return to_json({"version": version, **specification_json(spec), "pending": tools.pending()})

    @server.resource(INITIAL_SPECIFICATION_URI, name="initial-specification",
                     description="The specification the car started with (restore it when a situation is over).",
                     mime_type="application/json")
    def initial_specification() -> str:
        return to_json(specification_json(slot.initial))

    @server.resource(POOL_URI, name="pool", description="Every primitive objective family and its parameters.",
                     mime_type="application/json")
    def pool() -> str:
        return to_json({"pool": describe_pool()})

    @server.resource(TACTICS_URI, name="tactics", description="The driving tactics in force and the one that "
                     "steers path tracking (J1) to another lane now, if any: rule, lanes, obstacle, since when.",
                     mime_type="application/json")
    def tactics_now() -> str:
        return to_json(tactics() if tactics is not None else {"rules": [], "active": None})

    if route is not None:  # a world with junctions
        @server.resource(ROUTE_URI, name="route", description="Where the car is going: the route's edges, where "
                         "on it the car is, the next junction where the road divides (distance, the directions it "
                         "offers, where the route goes, the light) and the junctions ahead.",
                         mime_type="application/json")
        def route_now() -> str:
            return to_json(route())

    @server.resource(MEMORY_URI, name="memory", description="The agent's memory of this passenger across runs: "
                     "profile, file, standing preferences and entries (stated preferences, corrections).",
                     mime_type="application/json")
    def memory_now() -> str:
        return to_json((memory() if memory is not None else None) or {"profile": None, "entries": []})


def _observation_slice(latest_observation: ObservationSource, keys: dict[str, str]) -> Callable[[], str]:
    def read() -> str:
        obs = latest_observation()
        return to_json({"time_s": obs.get("time_s"),
                        **{out: obs.get(key, [] if key in _LISTS else None) for out, key in keys.items()}})

    return read


def specification_json(spec: Specification) -> dict[str, Any]:
    return {"summary": spec.summary(), "attached": spec.describe()}


def to_json(value: Any) -> str:
    """Strict JSON: a non-finite number (a broken observation) becomes null instead of invalid ``NaN``."""
    return json.dumps(_finite(value), default=str, allow_nan=False)


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: _finite(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(item) for item in value]
    return value
