"""The ego's way through a network: the route's edges (given, or found by SUMO's router) and the one chain of
lanes the ego drives along them, junctions' internal lanes included.

A road of parallel lanes (a carriageway whose lane count does not change and whose lanes continue straight on)
keeps one path per lane (:class:`~agentic_mpc.sumo.network.Road`). A route through junctions, turns and edges
whose lane count changes gets ONE path: on each edge the lane that leads on to the route's next edge, chosen
from the end backwards, so every lane of the chain is connected to the next; where the lane the ego arrives in
does not lead on, the path moves over to the one that does along that edge (a lane change the bicycle model
can follow: ``LANE_CHANGE_LENGTH_M``), as early as the edge allows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

CROSSING_POINTS = 16
"""Vertices of the curve that takes the ego through a junction."""
MAX_TRIM_M = 15.0
"""How far the curve may start before the stop line (and end past the junction) where the junction's own
geometry is unusable."""
LANE_CHANGE_LENGTH_M = 40.0
"""How long the path takes to move over one lane (shorter on shorter edges: at most half the edge)."""


class RouteError(ValueError):
    """A route that is not connected, names an edge that does not exist, or that SUMO cannot find."""


@dataclass(frozen=True, slots=True)
class ChainPiece:
    """One piece of the route's lane chain: the SUMO lanes it covers and the shape the ego follows there."""

    lane_ids: tuple[str, ...]
    """The lane the piece starts in first; a lane change's target lane second."""
    shape: tuple[tuple[float, float], ...]
    nominal_length_m: float
    """SUMO's length of the lane (positions on it are measured in it)."""
    internal: bool
    junction_id: str | None = None
    """The junction an internal lane belongs to."""


def connected_route(net: Any, edge_ids: tuple[str, ...], where: str) -> tuple[str, ...]:
    """``edge_ids`` checked: each edge exists and leads to the next; else a :class:`RouteError` naming it."""
    known = {e.getID() for e in net.getEdges(withInternal=False)}
    for edge_id in edge_ids:
        if edge_id not in known:
            raise RouteError(f"{where}: no edge {edge_id!r} in the network")
    for here, there in zip(edge_ids, edge_ids[1:]):
        onward = {e.getID() for e in net.getEdge(here).getOutgoing()}
        if there not in onward:
            raise RouteError(f"{where}: edge {here!r} does not lead to {there!r} (it leads to {sorted(onward)})")
    return edge_ids


def find_route(net: Any, from_edge: str, to_edge: str, where: str, vclass: str = "passenger") -> tuple[str, ...]:
    """The fastest route from ``from_edge`` to ``to_edge`` for ``vclass`` (sumolib's router, as SUMO's)."""
    for edge_id in (from_edge, to_edge):
        if not net.hasEdge(edge_id) or net.getEdge(edge_id).getFunction() == "internal":
            raise RouteError(f"{where}: no edge {edge_id!r} in the network")
    edges, _cost = net.getFastestPath(net.getEdge(from_edge), net.getEdge(to_edge), vClass=vclass)
    if not edges:
        raise RouteError(f"{where}: SUMO finds no route from {from_edge!r} to {to_edge!r} for {vclass}")
    return tuple(e.getID() for e in edges)


def junction_of(internal_lane_id: str) -> str:
    """The junction of an internal lane (SUMO names them ``:JUNCTION_LINK_LANE``)."""
    return internal_lane_id[1:].rsplit("_", 2)[0]


def _leads_to(lane: Any, edge_id: str, to_lane: Any | None = None) -> list[Any]:
    return [c for c in lane.getOutgoing() if c.getTo().getID() == edge_id and (to_lane is None or c.getToLane() is to_lane)]


def _usable(lane: Any, vclass: str) -> bool:
    return lane.allows(vclass)


def chosen_lanes(net: Any, edge_ids: tuple[str, ...], vclass: str = "passenger") -> list[tuple[Any, Any]]:
    """Per edge, (the lane the ego arrives in, the lane it leaves by), chosen from the route's end backwards.

    On the last edge the ego keeps the lane it arrives in. Before, it leaves each edge by the lane that leads to
    the next edge's arrival lane (the rightmost such in right-hand traffic order: SUMO's index 0 side), and
    arrives in the lane its predecessor's connection reaches."""
    edges = [net.getEdge(e) for e in edge_ids]
    leave: list[Any] = [None] * len(edges)
    arrive: list[Any] = [None] * len(edges)
    usable_last = [lane for lane in edges[-1].getLanes() if _usable(lane, vclass)] or edges[-1].getLanes()
    leave[-1] = usable_last[0]
    for k in range(len(edges) - 2, -1, -1):
        target = leave[k + 1]
        lanes = [lane for lane in edges[k].getLanes() if _usable(lane, vclass)] or edges[k].getLanes()
        direct = [lane for lane in lanes if _leads_to(lane, edge_ids[k + 1], target)]
        if direct:
            leave[k], arrive[k + 1] = direct[0], target
            continue
        onward = [lane for lane in lanes if _leads_to(lane, edge_ids[k + 1])]
        if not onward:
            raise RouteError(f"edge {edge_ids[k]!r} has no lane that leads to {edge_ids[k + 1]!r}")
        # arrive on the next edge in the lane nearest to the one it must leave by, and change lanes there
        options = [(lane, c.getToLane()) for lane in onward for c in _leads_to(lane, edge_ids[k + 1])]
        lane, to_lane = min(options, key=lambda o: (abs(o[1].getIndex() - target.getIndex()), o[0].getIndex()))
        leave[k], arrive[k + 1] = lane, to_lane
    arrive[0] = leave[0]
    return list(zip(arrive, leave))


def _shape(lane: Any) -> list[tuple[float, float]]:
    return [(float(p[0]), float(p[1])) for p in lane.getShape()]


def _resampled(shape: list[tuple[float, float]], s: np.ndarray) -> np.ndarray:
    xy = np.asarray(shape)
    cumulative = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    fraction = s * cumulative[-1]
    return np.column_stack([np.interp(fraction, cumulative, xy[:, 0]), np.interp(fraction, cumulative, xy[:, 1])])


def lane_change_shape(from_lane: Any, to_lane: Any) -> list[tuple[float, float]]:
    """The path along an edge from ``from_lane`` to ``to_lane`` (parallel lanes of it): along the first, over in a
    smooth S (cosine blend) of ``LANE_CHANGE_LENGTH_M`` per lane moved (at most half the edge), then the second."""
    length = from_lane.getLength()
    lanes_moved = abs(to_lane.getIndex() - from_lane.getIndex())
    change = min(LANE_CHANGE_LENGTH_M * lanes_moved, 0.5 * length)
    start = min(5.0, 0.25 * length)  # off the junction first
    count = max(8, int(math.ceil(length / 2.0)) + 1)
    s = np.linspace(0.0, 1.0, count)
    weight = np.clip((s * length - start) / change, 0.0, 1.0)
    weight = 0.5 - 0.5 * np.cos(math.pi * weight)
    blended = (1.0 - weight)[:, None] * _resampled(_shape(from_lane), s) + weight[:, None] * _resampled(
        _shape(to_lane), s)
    return [(float(x), float(y)) for x, y in blended]


def lane_chain(net: Any, edge_ids: tuple[str, ...], vclass: str = "passenger") -> list[ChainPiece]:
    """The pieces the ego drives along ``edge_ids`` (connected): each edge's lane(s) and the internal lanes
    between (:func:`chosen_lanes`)."""
    lanes = chosen_lanes(net, edge_ids, vclass)
    pieces: list[ChainPiece] = []
    for k, (arrive, leave) in enumerate(lanes):
        if arrive is leave:
            pieces.append(ChainPiece((arrive.getID(),), tuple(_shape(arrive)), arrive.getLength(), False))
        else:
            pieces.append(ChainPiece((arrive.getID(), leave.getID()), tuple(lane_change_shape(arrive, leave)),
                                     arrive.getLength(), False))
        if k + 1 == len(lanes):
            break
        connection = _leads_to(leave, edge_ids[k + 1], lanes[k + 1][0])[0]
        via = connection.getViaLaneID()
        while via:
            internal = net.getLane(via)
            pieces.append(ChainPiece((via,), tuple(_shape(internal)), internal.getLength(), True, junction_of(via)))
            onward = internal.getOutgoing()
            via = onward[0].getViaLaneID() if onward else ""
    return smooth_crossings(pieces)


def smooth_crossings(pieces: list[ChainPiece]) -> list[ChainPiece]:
    """Each junction's internal lanes as one smooth curve (a cubic Hermite) from the end of the lane before to
    the start of the lane after, as LimSim does: an OpenStreetMap import's internal lanes can run backwards
    (SUMO's ``DRT/osm.net.xml``: a 4.7 m internal lane pointing against both of its lanes), which no car can
    follow. Where even the lanes' ends point apart, the curve starts earlier and ends later (by up to
    ``MAX_TRIM_M``), shortening the lanes before and after."""
    out: list[ChainPiece] = []
    k = 0
    while k < len(pieces):
        piece = pieces[k]
        if not piece.internal or not out or out[-1].internal:
            out.append(piece)
            k += 1
            continue
        j = k
        while j < len(pieces) and pieces[j].internal:
            j += 1
        if j == len(pieces):  # the route ends inside a junction: keep its lanes
            out.extend(pieces[k:])
            break
        before, after = out[-1], pieces[j]
        internal = pieces[k:j]
        head, tail, curve = _crossing(before.shape, after.shape)
        out[-1] = _with_shape(before, head)
        out.append(ChainPiece(tuple(lane for p in internal for lane in p.lane_ids), tuple(curve),
                              sum(p.nominal_length_m for p in internal), True, internal[0].junction_id))
        out.append(_with_shape(after, tail))
        k = j + 1
    return out


def _with_shape(piece: ChainPiece, shape: list[tuple[float, float]]) -> ChainPiece:
    return ChainPiece(piece.lane_ids, tuple(shape), piece.nominal_length_m, piece.internal, piece.junction_id)


def _crossing(before: tuple, after: tuple) -> tuple[list, list, list]:
    """(the lane before, cut; the lane after, cut; the curve between): cut back 1 m at a time, up to MAX_TRIM_M
    from each end, until the chord runs forward along both lanes' directions."""
    head, tail = [tuple(p) for p in before], [tuple(p) for p in after]
    for _ in range(int(MAX_TRIM_M)):
        p0, p1 = np.asarray(head[-1]), np.asarray(tail[0])
        t0, t1 = _unit(np.subtract(head[-1], head[-2])), _unit(np.subtract(tail[1], tail[0]))
        chord = p1 - p0
        if chord @ t0 > 0.0 and chord @ t1 > 0.0:
            break
        if _length(head) > 2.0:
            head = _cut_end(head, 1.0)
        if _length(tail) > 2.0:
            tail = _cut_start(tail, 1.0)
    p0, p1 = np.asarray(head[-1]), np.asarray(tail[0])
    t0, t1 = _unit(np.subtract(head[-1], head[-2])), _unit(np.subtract(tail[1], tail[0]))
    scale = float(np.hypot(*(p1 - p0)))
    u = np.linspace(0.0, 1.0, CROSSING_POINTS)[:, None]
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    curve = h00 * p0 + h10 * scale * t0 + h01 * p1 + h11 * scale * t1
    return head, tail, [(float(x), float(y)) for x, y in curve]


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / max(float(np.hypot(*vector)), 1e-9)


def _length(shape: list) -> float:
    return sum(math.dist(a, b) for a, b in zip(shape, shape[1:]))


def _cut_end(shape: list, by_m: float) -> list:
    """``shape`` without its last ``by_m`` metres."""
    reversed_cut = _cut_start(shape[::-1], by_m)
    return reversed_cut[::-1]


def _cut_start(shape: list, by_m: float) -> list:
    """``shape`` without its first ``by_m`` metres."""
    left = by_m
    for i, (a, b) in enumerate(zip(shape, shape[1:])):
        step = math.dist(a, b)
        if step > left:
            f = left / step
            return [(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))] + list(shape[i + 1:])
        left -= step
    return list(shape[-2:])
