"""Where the scenario puts the ego, its vehicles and obstacles: a lane of the ego's road by index or role (or, for a
vehicle with a route of its own, SUMO's lane index on one of that route's edges), checked against the network
before SUMO starts; errors name the vehicle, the edge and the lane."""

from __future__ import annotations

from dataclasses import dataclass

from agentic_mpc.sumo.config import LaneRef, VehicleSpawn
from agentic_mpc.sumo.network import NetworkError, Road, RoadNetwork
from agentic_mpc.sumo.route import RouteError, connected_route
from agentic_mpc.world.base import WorldError


@dataclass
class Placement:
    """A position resolved against the network: edge, SUMO's lane index on it, front-bumper lane position."""

    edge_id: str
    lane_index: int
    pos_m: float


def place_on_road(road: Road, network: RoadNetwork, edge_id: str | None, lane: LaneRef, pos_m: float, what: str
                  ) -> Placement:
    """A lane of the ego's road (by index or role) on ``edge_id`` (default: the road's first edge)."""
    edge_id = edge_id or road.edge_ids[0]
    if edge_id not in road.edge_ids:
        raise WorldError(f"{what}: edge {edge_id!r} is not on the road {list(road.edge_ids)}")
    try:
        index = road.lane_index(lane)
    except NetworkError as error:
        raise WorldError(f"{what}: {error}") from error
    lane_id = road.sumo_lane_id(edge_id, index)
    index = int(lane_id.rsplit("_", 1)[1])  # SUMO's index on that edge from here on
    length = network.edge(edge_id).getLane(index).getLength()
    if not 0.0 <= pos_m <= length:
        raise WorldError(f"{what} is off the road: position {pos_m} m outside lane {edge_id}_{index} (0..{length:.1f} m)")
    return Placement(edge_id, index, pos_m)


def place_on_route(network: RoadNetwork, spawn: VehicleSpawn) -> Placement:
    """A vehicle with a route of its own: the route connected, its edge on it, its lane (SUMO's index) there."""
    what = f"vehicle {spawn.id!r}"
    try:
        connected_route(network.net, spawn.route or (), f"{what}: route")
    except RouteError as error:
        raise WorldError(str(error)) from None
    edge_id = spawn.edge_id or spawn.route[0]
    if edge_id not in spawn.route or not isinstance(spawn.lane, int):
        raise WorldError(f"{what}: edge {edge_id!r} must be on its route {list(spawn.route)}, lane an index")
    lanes = network.edge(edge_id).getLanes()
    if not 0 <= spawn.lane < len(lanes) or not 0.0 <= spawn.pos_m <= lanes[spawn.lane].getLength():
        raise WorldError(f"{what}: lane {spawn.lane} at {spawn.pos_m} m is not on edge {edge_id!r}")
    return Placement(edge_id, spawn.lane, spawn.pos_m)
