"""The junctions on the ego's route and what they say each step: the light for its movement, whether it gives way,
and how soon a vehicle with priority over it arrives (:class:`~agentic_mpc.world.observation.JunctionAhead`).

Which movement is the ego's comes from the network (the connection from the lane it arrives in, through the
junction's internal lanes); who crosses it from SUMO (``lane.getInternalFoes``, the junction's own logic); the
foes' arrival from the vehicles on the lanes that feed the crossing movements. Joints where a road merely
continues (no light, no crossing movement) are not junctions here.
"""

from __future__ import annotations

import functools
import gzip
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

from agentic_mpc.sumo.bridge import SumoBridge
from agentic_mpc.sumo.network import Road
from agentic_mpc.world.observation import JunctionAhead, VehicleObservation

SIGNALS = {"G": "green", "g": "green", "y": "yellow", "Y": "yellow", "r": "red", "u": "red", "s": "red",
           "o": "off", "O": "off"}
"""SUMO's link states as lights (``s``: a red that may be passed after stopping, rare; read as red)."""
DIRECTIONS = {"s": "straight", "l": "left", "L": "left", "r": "right", "R": "right", "t": "turn"}
STOPPED_BY_LIGHT = frozenset("ru")
"""A light's link states that hold a movement (red, red-yellow)."""
MINOR_STATES = frozenset("gmsw=")
"""Link states that give way: minor green, minor road, stop sign, all-way stop, right before left."""
LOOK_AHEAD_M = 200.0
"""Junctions further ahead are not reported."""
FOES_WITHIN_M = 80.0
"""Foes are looked for only when the ego is this close to the stop line."""
FOE_SPEED_FLOOR_MPS = 0.5
"""A foe slower than this further back than ``FOE_AT_LINE_M`` stands in a queue; at the line it may go any moment."""
FOE_AT_LINE_M = 3.0
FOE_LOOK_BACK_M = 80.0
"""How far back along the lanes that feed a crossing movement its vehicles are looked for."""
FOE_LANES = 8
INSIDE_PARTS = 3
"""How many internal lanes before a foe lane its movement is followed back through."""


@dataclass(frozen=True, slots=True)
class RouteJunction:
    """One junction of the route (static): where on the path, the ego's movement, its light."""

    junction_id: str
    stop_s_m: float
    exit_s_m: float
    direction: str
    internal_lanes: tuple[str, ...]
    tls_id: str
    link_index: int
    state: str
    """The connection's state in the network (``M`` major, ``m`` minor, ``s`` stop, ``w`` all-way stop, ...)."""
    wait_s_m: float | None = None
    """Where the ego's front waits inside the junction for a gap in the movements its turn crosses further in:
    the end of its first internal lane where SUMO has an internal junction there, on a turn across the oncoming
    traffic (left in right-hand traffic); None: it gives way at the line only. Not on other turns: waiting 43 m
    into an OpenStreetMap cluster on a right turn, the ego stood where cars going straight on a neighbouring
    internal lane did not see it, and three ran into it (unseen seeds 524, 528, 538)."""
    inside_foes: frozenset[str] = frozenset()
    """The internal lanes of the movements the ego waits for at ``wait_s_m`` (the internal junction's)."""


class RouteJunctions:
    """The route's junctions and, each step, the ones ahead as :class:`JunctionAhead` records."""

    def __init__(self, road: Road, bridge: SumoBridge, waved: dict[str, str] | None = None) -> None:
        self.road = road
        self.bridge = bridge
        self.waved: dict[str, str] = waved if waved is not None else {}
        """The cars the ego waved on that still go first: the lane each stood on (a route change keeps them)."""
        net = road.network.net
        junctions: list[RouteJunction] = []
        pieces = road.pieces
        internal_junctions = _internal_junctions(road.network.path)
        links: dict[str, Any] = {}  # per internal lane of the route: the ego's connection through that junction
        across = "right" if road.network.lefthand else "left"  # the turn across the oncoming traffic
        k = 0
        while k < len(pieces):
            piece, start = pieces[k]
            if piece.internal or k + 1 >= len(pieces) or not pieces[k + 1][0].internal:
                k += 1
                continue
            internal = []
            j = k + 1
            while j < len(pieces) and pieces[j][0].internal:
                internal.extend(pieces[j][0].lane_ids)  # a junction's internal lanes in order
                j += 1
            stop_s, exit_s = pieces[k + 1][1], pieces[j][1] if j < len(pieces) else road.reference.length_m
            leave = net.getLane(piece.lane_ids[-1])
            connection = next((c for c in leave.getOutgoing() if c.getViaLaneID() == internal[0]), None)
            k = j
            if connection is None:
                continue
            tls = connection.getTLSID() or ""
            if not tls and not any(bridge.internal_foes(lane) for lane in internal):
                continue  # the road just continues here
            direction = DIRECTIONS.get(connection.getDirection(), "straight")
            waiting = _waiting_point(net, internal, road.spans[internal[1]].start_s_m if len(internal) > 1 else 0.0,
                                     internal_junctions) if direction == across else ()
            links.update((lane, connection) for lane in internal)
            junctions.append(RouteJunction(
                pieces[k - 1][0].junction_id or "", stop_s, exit_s, direction,
                tuple(internal), tls, connection.getTLLinkIndex() if tls else -1, connection.getState(), *waiting))
        self.junctions: tuple[RouteJunction, ...] = tuple(junctions)
        self._route_edges = frozenset(road.edge_ids)
        self.tls_ids = tuple(sorted({j.tls_id for j in junctions if j.tls_id}))
        self._feeders = {lane: self._feeding(lane, links[lane]) for j in junctions for lane in j.internal_lanes}
        self._ahead: tuple[JunctionAhead, ...] = ()
        self._told_stopping: bool | None = None  # what SUMO was last told (None: nothing yet)

    def _feeding(self, internal_lane: str, own_link: Any) -> tuple[tuple[str, int, str, str, tuple[tuple[
            str, float, float], ...], tuple[str, ...], bool | None], ...]:
        """Per movement that crosses ``internal_lane`` (its foe lane and a lane that feeds it): (the foe internal
        lane, its link index, its tls, its state in the network, the lanes that lead to it: (lane id, its length,
        how far its end lies before the junction), the internal lanes between the junction's edge and the foe
        lane, whether the junction's logic makes the ego's link (``own_link``) give way to it: SUMO's response
        matrix, None where the network has none). The lanes are followed back :data:`FOE_LOOK_BACK_M`: an
        OpenStreetMap junction's feeding lane can be a few metres long, and a car on the lane before appears at the
        line as if from nowhere; and through the foe lane's internal predecessors: in a cluster a movement's
        crossing part can be its second internal lane, and a car on the first is already on its way (tuning seed
        303, t = 495 s)."""
        net = self.road.network.net
        feeders = []
        for foe in self.bridge.internal_foes(internal_lane):
            for incoming, inside in _entries(net.getLane(foe), self._route_edges):
                first = inside[0] if inside else foe
                connection = next((c for c in incoming.getOutgoing() if c.getViaLaneID() == first), None)
                if connection is None:
                    continue
                tls = connection.getTLSID() or ""
                feeders.append((foe, connection.getTLLinkIndex() if tls else -1, tls, connection.getState(),
                                _upstream(incoming, self._route_edges), inside, _forbids(connection, own_link)))
        return tuple(feeders)

    def ahead(self, front_s_m: float) -> tuple[JunctionAhead, ...]:
        """The junctions the ego's front has not left, within :data:`LOOK_AHEAD_M`, nearest first."""
        upcoming = [j for j in self.junctions if j.exit_s_m > front_s_m and j.stop_s_m - front_s_m < LOOK_AHEAD_M]
        if not upcoming:
            self._ahead = ()
            return ()
        states = self.bridge.signal_states(tuple({j.tls_id for j in upcoming if j.tls_id}))
        self._ahead = tuple(self._ahead_of(j, front_s_m, states) for j in upcoming[:2])
        return self._ahead

    def tell_light_stop(self, ego_id: str, stop_line_s_m: float | None) -> None:
        """Tell SUMO whether the ego stops at a light: the junction rules' stop line (None: no stop) is that of a
        junction ahead whose light is red or yellow. SUMO's junction logic otherwise takes the externally driven
        ego to pass every light, and its drivers wait for an ego that stands at its red light
        (:data:`~agentic_mpc.sumo.bridge.vehicles.STOPPING_AT_LIGHT_SPEED_MODE`)."""
        stopping = stop_line_s_m is not None and any(
            j.stop_s_m == stop_line_s_m and j.signal in ("red", "yellow") for j in self._ahead)
        if stopping != self._told_stopping:
            self.bridge.stop_external_at_light(ego_id, stopping)
            self._told_stopping = stopping

    def let_go_first(self, ego_id: str, vehicle_id: str | None, traffic: tuple[VehicleObservation, ...]) -> None:
        """Tell SUMO's driver of the car the tactics wave on (``vehicle_id``) to go before the ego, and each car
        waved on before to give way to it again once it has left the junction: it is then on a lane that is
        neither internal nor the one it stood on (or out of sight)."""
        lanes = {vehicle.id: vehicle.lane_id for vehicle in traffic}
        for waved, stood_on in list(self.waved.items()):
            lane = lanes.get(waved)
            if lane is None or lane != stood_on and not lane.startswith(":"):
                self.bridge.let_go_first(waved, ego_id, first=False)
                del self.waved[waved]
        if vehicle_id is not None and vehicle_id in lanes:
            self.bridge.let_go_first(vehicle_id, ego_id)
            self.waved[vehicle_id] = lanes[vehicle_id]

    def _ahead_of(self, junction: RouteJunction, front_s_m: float, states: dict[str, str]) -> JunctionAhead:
        char = states[junction.tls_id][junction.link_index] if junction.tls_id else junction.state
        must_yield = char in MINOR_STATES
        distance = junction.stop_s_m - front_s_m
        foe_arrival = inside_arrival = None
        waits_inside = junction.wait_s_m is not None and front_s_m < junction.wait_s_m
        if must_yield and distance < FOES_WITHIN_M:
            foe_arrival = self._foe_arrival_s(junction, states, char, inside=False)
            if waits_inside:
                inside_arrival = self._foe_arrival_s(junction, states, char, inside=True)
        return JunctionAhead(
            junction.junction_id, junction.stop_s_m, junction.exit_s_m, distance, junction.direction,  # type: ignore[arg-type]
            SIGNALS.get(char) if junction.tls_id else None, must_yield, char in "sw", foe_arrival,
            junction.wait_s_m, inside_arrival)

    def _foe_arrival_s(self, junction: RouteJunction, states: dict[str, str], own: str, inside: bool
                       ) -> float | None:
        """The soonest a vehicle on a crossing movement that has priority over the ego's reaches the junction (one
        already on such a movement inside it: 0). Priority: the junction's logic (SUMO's response matrix: a left
        turn gives way to the oncoming right turn into its lane though both have a minor green, tuning seed 303);
        where the network has none, a major green against a minor one, a major road against a minor road or a stop
        sign; every movement at right-before-left or an all-way stop; a movement whose light is red has none.
        Where the ego waits inside (``wait_s_m``): the movements it waits for there (``inside``: all that SUMO's
        internal junction names) or the others."""
        soonest: float | None = None
        for lane in junction.internal_lanes:
            for foe, link_index, tls, state, upstream, parts, forbids in self._feeders[lane]:
                if (foe in junction.inside_foes) != inside:
                    continue
                foe_state = states.get(tls, "r")[link_index] if tls else state
                if tls and foe_state in STOPPED_BY_LIGHT or not (
                        inside or (forbids if forbids is not None and own not in "=w" else _has_priority_over(
                            foe_state, own))):
                    continue  # stopped by its light, or giving way itself
                if self.bridge.approaching(foe, 0.0) or any(
                        speed >= FOE_SPEED_FLOOR_MPS for part in parts for _, _, speed in self.bridge.approaching(
                            part, 0.0)):
                    return 0.0  # on the movement inside the junction (standing before its crossing part: it waits)
                for feeder, length, before_m in upstream:
                    for _vehicle_id, distance_m, speed_mps in self.bridge.approaching(feeder, length):
                        distance_m += before_m
                        if speed_mps < FOE_SPEED_FLOOR_MPS and distance_m > FOE_AT_LINE_M:
                            continue  # standing in a queue further back
                        arrival = distance_m / max(speed_mps, FOE_SPEED_FLOOR_MPS)
                        soonest = arrival if soonest is None else min(soonest, arrival)
        return soonest


def _waiting_point(net: Any, internal: list[str], second_s_m: float, internal_junctions: dict[str, frozenset[str]]
                   ) -> tuple[float, frozenset[str]] | tuple[()]:
    """(where the front waits, the internal lanes it waits for) where the route's way through a junction goes on
    from its first internal lane through an internal junction (SUMO's waiting point: where the second internal
    lane, at ``second_s_m`` on the path, begins), else ()."""
    waits_for = internal_junctions.get(internal[1]) if len(internal) > 1 else None
    first = net.getLane(internal[0])
    if not waits_for or not any(c.getToLane().getID() == internal[1] or c.getViaLaneID() == internal[1]
                                for c in first.getOutgoing()):
        return ()  # no waiting point, or a carriageway's parallel internal lanes
    return second_s_m, waits_for


@functools.lru_cache(maxsize=4)
def _internal_junctions(net_path: Path) -> dict[str, frozenset[str]]:
    """The network's internal junctions (SUMO's waiting points inside a junction): the id of the internal lane
    that goes on from one -> the internal lanes whose vehicles a vehicle waiting there gives way to. sumolib
    does not read them; a pass over the file's ``junction`` elements does."""
    found: dict[str, frozenset[str]] = {}
    opener = gzip.open if net_path.suffix == ".gz" else open
    with opener(net_path, "rb") as stream:
        for _, element in ElementTree.iterparse(stream):
            if element.tag == "junction" and element.get("type") == "internal":
                found[element.get("id", "")] = frozenset(element.get("intLanes", "").split())
            if element.tag in ("junction", "edge", "connection", "tlLogic"):
                element.clear()  # a city's network: keep only what is read
    return found


def _entries(foe_lane: Any, route_edges: frozenset[str]) -> list[tuple[Any, tuple[str, ...]]]:
    """(a lane that enters the junction towards ``foe_lane``, the internal lanes between it and ``foe_lane``) for
    each way a movement reaches the foe lane, back through at most :data:`INSIDE_PARTS` internal lanes; none from
    the ego's own route (it merges, not crosses)."""
    found: list[tuple[Any, tuple[str, ...]]] = []
    frontier: list[tuple[Any, tuple[str, ...]]] = [(foe_lane, ())]
    while frontier:
        lane, inside = frontier.pop()
        for incoming in lane.getIncoming():
            if incoming.getEdge().getFunction() == "internal":
                if len(inside) < INSIDE_PARTS and incoming.getID() not in inside:
                    frontier.append((incoming, (incoming.getID(), *inside)))
            elif incoming.getEdge().getID() not in route_edges:
                found.append((incoming, inside))
    return found


def _upstream(lane: Any, route_edges: frozenset[str]) -> tuple[tuple[str, float, float], ...]:
    """``lane`` and the normal lanes before it, (id, length, distance from its end to ``lane``'s end), back to
    :data:`FOE_LOOK_BACK_M` (at most :data:`FOE_LANES` lanes), none of the ego's route (on an OpenStreetMap
    cluster the lane the ego waits in can lead round to a crossing movement: the ego must not wait for itself)."""
    found = [(lane.getID(), lane.getLength(), 0.0)]
    frontier = [(lane, 0.0)]
    while frontier and len(found) < FOE_LANES:
        current, before = frontier.pop(0)
        reach = before + current.getLength()
        if reach >= FOE_LOOK_BACK_M:
            continue
        for previous in current.getIncoming():
            edge = previous.getEdge()
            if (edge.getFunction() != "internal" and edge.getID() not in route_edges
                    and previous.getID() not in {f[0] for f in found}):
                found.append((previous.getID(), previous.getLength(), reach))
                frontier.append((previous, reach))
    return tuple(found[:FOE_LANES])


def _forbids(foe_link: Any, own_link: Any) -> bool | None:
    """Whether the junction's logic makes ``own_link`` give way to ``foe_link`` (None: it has no logic for them)."""
    try:
        return bool(own_link.getFrom().getToNode().forbids(foe_link, own_link))
    except (KeyError, IndexError, AttributeError):
        return None


def _has_priority_over(foe_state: str, own_state: str) -> bool:
    """Whether a movement in ``foe_state`` goes before one in ``own_state`` (SUMO's link state characters)."""
    if own_state in "=w":  # right before left, all-way stop: everyone there first, the ego waits for all
        return foe_state in "=wMGO"
    return foe_state in "MGO"  # a major road or a major green (O: a light that is off, read as major)
