"""Choosing the way at a junction: which directions the next junction offers, and the route after a turn or to a
destination, from the network alone (sumolib): the SUMO world then drives the new route
(:meth:`~agentic_mpc.sumo.world.SumoWorld.reroute`).

A junction offers a direction where the edge the ego arrives on has a connection of that kind (SUMO's ``s``,
``l``/``L``, ``r``/``R``; U-turns are not offered) to another edge. After a turn the route goes straight on
(SUMO's ``s`` connections) while the road continues, up to ``CONTINUE_M``; a destination is routed by SUMO's
router from the edge of the junction ahead.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from agentic_mpc.sumo.route import RouteError, find_route

DIRECTION_OF = {"s": "straight", "l": "left", "L": "left", "r": "right", "R": "right"}
CONTINUE_M = 2000.0
"""How far a route goes straight on after a turn (it ends earlier where the road does)."""


@dataclass(frozen=True, slots=True)
class JunctionChoice:
    """The next junction on the route with more than one way on: the edge the ego arrives on and where each
    direction leads."""

    junction_id: str
    incoming_edge: str
    index: int
    """The incoming edge's place in the route."""
    directions: dict[str, str]
    """direction ("left", "right", "straight") -> the edge it leads to."""
    route_direction: str
    """The direction the route takes there now."""


def offered(net: Any, edge_id: str) -> dict[str, str]:
    """direction -> the edge it leads to, of the connections from ``edge_id`` (the first edge of each kind)."""
    directions: dict[str, str] = {}
    for to_edge, connections in net.getEdge(edge_id).getOutgoing().items():
        for connection in connections:
            direction = DIRECTION_OF.get(connection.getDirection())
            if direction is not None and to_edge.getFunction() != "internal":
                directions.setdefault(direction, to_edge.getID())
    return directions


def next_choice(net: Any, edge_ids: tuple[str, ...], from_index: int) -> JunctionChoice | None:
    """The first junction at or after route edge ``from_index`` where the road offers more than one way on."""
    for index in range(from_index, len(edge_ids) - 1):
        directions = offered(net, edge_ids[index])
        if len(directions) > 1:
            here = net.getEdge(edge_ids[index])
            taken = next((d for d, e in directions.items() if e == edge_ids[index + 1]), "straight")
            return JunctionChoice(here.getToNode().getID(), edge_ids[index], index, directions, taken)
    return None


def straight_on(net: Any, edge_id: str, length_m: float = CONTINUE_M) -> tuple[str, ...]:
    """``edge_id`` and the edges straight on after it while the road continues, up to ``length_m``."""
    edges = [edge_id]
    covered = net.getEdge(edge_id).getLength()
    while covered < length_m:
        onward = offered(net, edges[-1]).get("straight")
        if onward is None or onward in edges:
            break
        edges.append(onward)
        covered += net.getEdge(onward).getLength()
    return tuple(edges)


def turned_route(net: Any, edge_ids: tuple[str, ...], from_index: int, direction: str) -> tuple[str, ...]:
    """The route with the next junction at or after ``from_index`` taken in ``direction``; a
    :class:`RouteError` says what the junction offers if not that."""
    choice = next_choice(net, edge_ids, from_index)
    if choice is None:
        raise RouteError("there is no junction ahead on the route where the road divides")
    if direction not in choice.directions:
        offers = " and ".join(sorted(choice.directions))
        raise RouteError(f"the junction ahead ({choice.junction_id}) offers {offers}, not {direction}")
    return edge_ids[: choice.index + 1] + straight_on(net, choice.directions[direction])


def route_to(net: Any, edge_ids: tuple[str, ...], from_index: int, destination: str) -> tuple[str, ...]:
    """The route from route edge ``from_index`` on to ``destination`` (SUMO's router), the edges before kept."""
    return edge_ids[:from_index] + find_route(net, edge_ids[from_index], destination, "destination")
