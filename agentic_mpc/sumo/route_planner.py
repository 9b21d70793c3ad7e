"""The SUMO world's :class:`~agentic_mpc.world.routes.RoutePlanner`: the next junction where the road divides,
a turn there or a destination planned on the network (:mod:`agentic_mpc.sumo.turns`), and the new route handed to
the world, which drives it from its next step (:meth:`~agentic_mpc.sumo.world.SumoWorld.use_route`)."""

from __future__ import annotations

from typing import Any

from agentic_mpc.geometry import LanePath
from agentic_mpc.sumo.network import NetworkError, Road
from agentic_mpc.sumo.route import RouteError
from agentic_mpc.sumo.turns import next_choice, route_to, turned_route
from agentic_mpc.world.routes import RouteRefused


def has_choices(road: Road) -> bool:
    """Whether the road divides anywhere along it (else there is no way to choose: no route tools)."""
    return next_choice(road.network.net, road.edge_ids, 0) is not None


class SumoRoutePlanner:
    """Plans on ``world``'s network from where the ego is on its road now."""

    def __init__(self, world: Any) -> None:
        self.world = world

    def _edge_index(self) -> int:
        """The route edge the ego is on (inside a junction: the edge it came from)."""
        road, s = self.world.road, self.world.observation.ego.road_s_m
        edges = [piece.lane_ids[0].rsplit("_", 1)[0] for piece, start in road.pieces if not piece.internal
                 and start <= s + 0.5 * self.world.ego_length_m]
        return road.edge_ids.index(edges[-1]) if edges else 0

    def describe(self) -> dict[str, Any]:
        road = self.world.road
        index = self._edge_index()
        choice = next_choice(road.network.net, road.edge_ids, index)
        ahead = {j.junction_id: j for j in self.world.observation.junctions_ahead}
        junction = None
        if choice is not None:
            seen = ahead.get(choice.junction_id)
            junction = {"junction_id": choice.junction_id, "directions": sorted(choice.directions),
                        "route_goes": choice.route_direction,
                        "distance_m": round(seen.distance_m, 1) if seen is not None else None,
                        "signal": seen.signal if seen is not None else None}
        return {"edges": list(road.edge_ids), "on_edge": road.edge_ids[index], "length_m": round(road.reference.length_m, 1),
                "goal_s_m": round(self.world.goal_s_m, 1), "ego_s_m": round(self.world.observation.ego.road_s_m, 1),
                "next_choice": junction,
                "junctions_ahead": [j.to_json() for j in self.world.observation.junctions_ahead]}

    def plan_turn(self, direction: str) -> Road:
        road = self.world.road
        try:
            return self._road(turned_route(road.network.net, road.edge_ids, self._edge_index(), direction))
        except RouteError as error:
            raise RouteRefused(str(error)) from None

    def plan_destination(self, edge_id: str) -> Road:
        road = self.world.road
        try:
            return self._road(route_to(road.network.net, road.edge_ids, self._edge_index(), edge_id))
        except RouteError as error:
            raise RouteRefused(str(error).replace("destination: ", "")) from None

    def _road(self, edge_ids: tuple[str, ...]) -> Road:
        try:
            return self.world.network.road(edge_ids)
        except NetworkError as error:
            raise RouteRefused(str(error)) from None

    def follow(self, plan: Road) -> LanePath:
        self.world.use_route(plan)
        roles = plan.lane_roles()
        return plan.lane_paths[roles.get("center", roles.get("right", 0))]
