"""The road a recorded run drove on, rebuilt from its ``scenario.json`` without a simulation: SUMO's network
file (read with sumolib) or the plain world's road. The figures, ``agentic-mpc plot`` and the replay (its page,
its animation and the live view) draw the road from here.

No matplotlib here (the replay page draws in the browser).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from agentic_mpc.geometry import LanePath
from agentic_mpc.world.lanes import RoadLanes


@dataclass(frozen=True)
class RunRoad:
    """A rebuilt road: a lanes source as a world is one (:meth:`lanes`), and its lane centre lines left to right
    with their widths and the road's two edges (left, right)."""

    road_lanes: RoadLanes
    left_to_right: tuple[LanePath, ...]
    widths_m: tuple[float, ...]
    edges: tuple[LanePath, LanePath]

    def lanes(self) -> RoadLanes:
        return self.road_lanes


def run_road(scenario: Mapping[str, Any]) -> RunRoad | None:
    """The road of the run whose scenario (``scenario.json``) is ``scenario``, drawn by its world kind
    (agentic_mpc/worlds.py); None for one without a known world."""
    from agentic_mpc.worlds import WORLD_KINDS

    for key, kind in WORLD_KINDS.items():
        if scenario.get(key):
            return kind.road_drawing(scenario[key])
    return None


def _road_key(road: Any) -> Any:
    """The road as :meth:`~agentic_mpc.sumo.network.RoadNetwork.road` takes it, hashable for the caches here: a
    route by its ends (``scenario.json``'s ``{from_edge, via, to_edge}``) as the config's ``RouteEnds`` (frozen)."""
    if isinstance(road, Mapping):
        from agentic_mpc.sumo.config import RouteEnds

        return RouteEnds.model_validate(road)
    return tuple(road) if isinstance(road, list) else road


def sumo_road(simulation: Mapping[str, Any]) -> RunRoad:
    """A SUMO world's road from its ``simulation`` mapping (the network file read with sumolib)."""
    return _sumo_road(simulation["net_file"], _road_key(simulation["road"]))


@lru_cache(maxsize=4)
def _network(net_file: str) -> Any:
    """Cached: a batch's runs share a few networks, and reading one takes a while."""
    from agentic_mpc.sumo.network import RoadNetwork

    return RoadNetwork(net_file)


def sumo_network_and_road(simulation: Mapping[str, Any]) -> tuple[Any, Any]:
    """The :class:`~agentic_mpc.sumo.network.RoadNetwork` and :class:`~agentic_mpc.sumo.network.Road` of a SUMO
    run's ``simulation`` mapping."""
    network = _network(simulation["net_file"])
    return network, network.road(_road_key(simulation["road"]))


@lru_cache(maxsize=16)
def _sumo_road(net_file: str, road: Any) -> RunRoad:
    network = _network(net_file)
    sumo_road = network.road(road)
    lanes = {role: sumo_road.lane_paths[i] for role, i in sumo_road.lane_roles().items()}
    limit = min(network.edge(edge_id).getSpeed() for edge_id in sumo_road.edge_ids)
    order = sumo_road.left_to_right
    return RunRoad(RoadLanes(lanes, float(limit), sumo_road.lefthand), tuple(sumo_road.lane_paths[i] for i in order),
                   tuple(sumo_road.lane_widths_m[i] for i in order), (sumo_road.left_edge, sumo_road.right_edge))


def plain_road(config: Mapping[str, Any]) -> RunRoad:
    """The plain-Python world's road from its ``plain_world`` mapping."""
    from agentic_mpc.world.plain import PlainWorld
    from agentic_mpc.world.plain_config import PlainConfig

    world = PlainWorld(PlainConfig.model_validate(config))
    try:
        lanes = world.lanes()
        width = float(world.config.road.lane_width_m)
    finally:
        world.close()
    paths = sorted(lanes.lanes.values(), key=lambda p: -float(p.coordinates[0][1]))  # along +x: left is +y
    return RunRoad(lanes, tuple(paths), (width,) * len(paths), (paths[0].parallel(width / 2),
                                                                 paths[-1].parallel(-width / 2)))
