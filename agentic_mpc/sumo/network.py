"""Lane geometry of a SUMO network, read with sumolib, as the controller's :class:`LanePath`\\ s.

A :class:`Road` is one carriageway: a chain of edges with the same number of lanes, driven straight through.
Each lane index becomes one continuous :class:`LanePath` through the whole chain (the junctions' internal
lanes included), so the path tracking objective J1 can follow "the centre lane" from start to goal.

Lanes are named by where they lie, not by SUMO's index: in right-hand nets lane 0 is the rightmost, in
left-hand nets (``netconvert --lefthand``) the leftmost, so "left"/"center"/"right" are found geometrically.

Positions: SUMO measures a lane position in the lane's *nominal* length, which on curves differs from the
length of its drawn shape (all lanes of an edge share one nominal length). :meth:`Road.lane_s` converts a
SUMO lane position to arc length on our path with the lane's geometry factor, as SUMO itself does.
"""

from __future__ import annotations

import bisect
import functools
import math
import xml.sax
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import sumolib
from numpy.typing import ArrayLike, NDArray

from agentic_mpc.geometry import LanePath
from agentic_mpc.polylines.polyline import Polyline
from agentic_mpc.sumo.route import ChainPiece, RouteError, connected_route, find_route, junction_of, lane_chain


class NetworkError(ValueError):
    """A network file that is missing or malformed, or a road that cannot be built from it."""


@dataclass(frozen=True, slots=True)
class LaneSpan:
    """Where one SUMO lane (normal or junction-internal) lies on a road lane's path."""

    lane_id: str
    road_lane_index: int
    start_s_m: float
    """Arc length on the road lane's path where this SUMO lane begins."""
    shape_length_m: float
    geometry_factor: float
    """shape length / SUMO's nominal lane length: SUMO lane position * factor = arc length on the shape."""


class Road:
    """One carriageway through a chain of edges: lane paths, road edge lines, along-road coordinates."""

    def __init__(self, network: RoadNetwork, edge_ids: tuple[str, ...],
                 chains: list[list[ChainPiece]] | None = None) -> None:
        if not edge_ids:
            raise NetworkError(f"{network.path.name}: a road needs at least one edge")
        self.network = network
        self.edge_ids = edge_ids
        self.is_route = chains is not None
        """One path along a route through junctions (:mod:`agentic_mpc.sumo.route`), not a carriageway's lanes."""
        if chains is None:
            chains = self._carriageway_chains(network, edge_ids)
        lane_count = self.lane_count = len(chains)
        spans: dict[str, LaneSpan] = {}
        paths: list[LanePath] = []
        widths: list[float] = []
        self.pieces: tuple[tuple[ChainPiece, float], ...] = ()
        """(piece, where it starts on the path) of lane 0's chain: the route's lanes and junctions in order."""
        for index, chain in enumerate(chains):
            coordinates: list[tuple[float, float]] = []
            s = 0.0
            starts = []
            for piece in chain:
                shape = piece.shape
                shape_length = sum(math.dist(a, b) for a, b in zip(shape, shape[1:]))
                if coordinates:
                    s += math.dist(coordinates[-1], shape[0])  # consecutive shapes normally touch
                nominal = piece.nominal_length_m
                factor = shape_length / nominal if nominal > 0 else 1.0
                before = 0.0  # a junction's internal lanes one after another: each starts where the last ends
                for lane_id in piece.lane_ids:  # (an edge's lanes, where the path moves over, lie side by side)
                    spans.setdefault(lane_id, LaneSpan(lane_id, index, s + before * factor, shape_length, factor))
                    before += network.net.getLane(lane_id).getLength() if piece.internal else 0.0
                starts.append((piece, s))
                coordinates.extend(shape)  # LanePath drops the repeated joint vertex
                s += shape_length
            if index == 0:
                self.pieces = tuple(starts)
            paths.append(LanePath(np.array(coordinates), name=f"{edge_ids[0]}..{edge_ids[-1]}#{index}"))
            widths.append(network.net.getLane(chain[0].lane_ids[0]).getWidth())
        self.spans = spans
        self.lane_paths: tuple[LanePath, ...] = tuple(paths)
        self.lane_widths_m: tuple[float, ...] = tuple(widths)
        # Left-to-right order from geometry: lane 0 left of the last lane means a left-hand net.
        if lane_count > 1:
            mid = paths[0].points_at([paths[0].length_m / 2])[0]
            self.lefthand = float(paths[-1].lateral_offset(mid[0], mid[1])[0]) > 0.0
        else:
            self.lefthand = network.lefthand
        self.left_to_right: tuple[int, ...] = (
            tuple(range(lane_count)) if self.lefthand else tuple(reversed(range(lane_count)))
        )
        leftmost, rightmost = self.left_to_right[0], self.left_to_right[-1]
        self.left_edge = paths[leftmost].parallel(widths[leftmost] / 2, name="road left edge")
        self.right_edge = paths[rightmost].parallel(-widths[rightmost] / 2, name="road right edge")
        self.width_m = float(sum(widths))
        # A route's one lane is its own centre line (an offset of an offset would cut a junction's tight turns).
        self.reference = paths[0] if self.is_route else self.left_edge.parallel(-self.width_m / 2,
                                                                                 name="road centre line")
        """The line along-road distances are measured on (the middle of the carriageway)."""
        # Arc length on each lane path -> arc length on the reference: lanes are parallel to it, so a table
        # at the lane's vertices interpolates exactly enough and costs one np.interp per query.
        self._to_reference = []
        for path in paths:
            xy = path.coordinates
            ref_s = shapely.line_locate_point(self.reference.line, shapely.points(xy[:, 0], xy[:, 1]))
            lane_s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
            self._to_reference.append((lane_s, np.maximum.accumulate(ref_s)))
        self._to_reference_lists = [(a.tolist(), b.tolist()) for a, b in self._to_reference]
        self.lane_tables: tuple[Polyline, ...] = tuple(Polyline(path) for path in paths)
        self.reference_table = Polyline(self.reference)
        order = self.left_to_right
        roles = {"left": order[0], "right": order[-1]}
        if lane_count % 2 == 1:
            roles["center"] = order[lane_count // 2]
        if lane_count == 1:
            roles = {"center": order[0]}
        self._roles = roles
        self._role_of = {i: role for role, i in roles.items()}

    @staticmethod
    def _carriageway_chains(network: RoadNetwork, edge_ids: tuple[str, ...]) -> list[list[ChainPiece]]:
        """One chain per lane index through edges of one lane count (:class:`NetworkError` if they are not)."""
        edges = [network.edge(e) for e in edge_ids]
        lane_count = len(edges[0].getLanes())
        for edge in edges[1:]:
            if len(edge.getLanes()) != lane_count:
                raise NetworkError(
                    f"{network.path.name}: road {list(edge_ids)} changes its lane count at edge {edge.getID()!r}"
                    f" ({lane_count} -> {len(edge.getLanes())}); a Road needs one lane count throughout"
                )
        return [[ChainPiece((lane.getID(),), tuple((float(p[0]), float(p[1])) for p in lane.getShape()),
                            lane.getLength(), lane.getEdge().getFunction() == "internal",
                            junction_of(lane.getID()) if lane.getID().startswith(":") else None)
                 for lane in Road._lane_chain(network.net, edges, index)] for index in range(lane_count)]

    @staticmethod
    def _lane_chain(net: sumolib.net.Net, edges: list, index: int) -> list:
        """The SUMO lanes a vehicle passes keeping lane ``index`` through the edges (internal lanes included)."""
        chain = [edges[0].getLane(index)]
        for edge, successor in zip(edges, edges[1:]):
            lane = edge.getLane(index)
            connections = [c for c in lane.getOutgoing() if c.getTo().getID() == successor.getID()]
            if not connections:
                raise NetworkError(
                    f"{edge.getID()!r} lane {index} has no connection to {successor.getID()!r}: not one road"
                )
            connection = min(connections, key=lambda c: abs(c.getToLane().getIndex() - index))
            via = connection.getViaLaneID()
            while via:
                internal = net.getLane(via)
                chain.append(internal)
                onward = internal.getOutgoing()
                via = onward[0].getViaLaneID() if onward else ""
            chain.append(connection.getToLane())
        return chain

    # --- lanes by name -------------------------------------------------------------------------------
    @functools.cached_property
    def lane_bounds_m(self) -> tuple[tuple[float, float], ...]:
        """Each lane's (left, right) line, lateral from the road's centre line (positive to the left), by lane
        index; measured mid-road (lanes run parallel to the centre line)."""
        middle = self.reference.points_at([0.5 * self.reference.length_m])[0]
        bounds = []
        for index, path in enumerate(self.lane_paths):
            x, y = path.points_at([path.project(*middle)])[0]
            centre, half = float(self.lateral_from_reference(x, y)[0]), 0.5 * self.lane_widths_m[index]
            bounds.append((centre + half, centre - half))
        return tuple(bounds)

    def lane_roles(self) -> dict[str, int]:
        """"left", "right" and (for an odd count) "center" mapped to SUMO lane indices."""
        return dict(self._roles)

    def lane_index(self, lane: int | str) -> int:
        """A lane index from an index or a role ("left", "center", "right")."""
        if isinstance(lane, str):
            roles = self.lane_roles()
            if lane not in roles:
                raise NetworkError(f"road has no {lane!r} lane; it has {sorted(roles)} ({self.lane_count} lanes)")
            return roles[lane]
        if not 0 <= lane < self.lane_count:
            raise NetworkError(f"lane index {lane} out of range: the road has {self.lane_count} lanes")
        return lane

    def lane_role(self, index: int) -> str:
        """The role of a lane index ("left"/"center"/"right"), or "lane<i>" for the others."""
        return self._role_of.get(index) or f"lane{index}"

    def lane_path(self, lane: int | str) -> LanePath:
        """The centre line of a lane through the whole road, by index or role."""
        return self.lane_paths[self.lane_index(lane)]

    @functools.cached_property
    def speed_limit_mps(self) -> float:
        """A carriageway's lowest limit; a route's highest (its slower stretches are :attr:`speed_zones`)."""
        speeds = [self.network.edge(e).getSpeed() for e in self.edge_ids]
        return float(max(speeds) if self.is_route else min(speeds))

    @functools.cached_property
    def speed_zones(self) -> tuple[tuple[float, float, float], ...]:
        """(start, end along the path, limit) of lane 0's pieces slower than :attr:`speed_limit_mps` (a turn's
        internal lanes, a slower street), neighbours with one limit joined."""
        zones: list[tuple[float, float, float]] = []
        for n, (piece, start) in enumerate(self.pieces):
            end = self.pieces[n + 1][1] if n + 1 < len(self.pieces) else self.reference.length_m
            limit = min(self.network.net.getLane(lane).getSpeed() for lane in piece.lane_ids)
            if limit >= self.speed_limit_mps:
                continue
            if zones and zones[-1][2] == limit and abs(zones[-1][1] - start) < 1e-6:
                zones[-1] = (zones[-1][0], end, limit)
            else:
                zones.append((start, end, float(limit)))
        return tuple(zones)

    def sumo_lane_id(self, edge_id: str, index: int) -> str:
        """SUMO's id of road lane ``index`` on ``edge_id``: the same index on a carriageway; on a route the lane
        the ego arrives in on that edge."""
        if self.is_route:
            piece = next((p for p, _ in self.pieces if not p.internal and p.lane_ids[0].rsplit("_", 1)[0] == edge_id),
                         None)
            if piece is None:
                raise NetworkError(f"edge {edge_id!r} is not on the route {list(self.edge_ids)}")
            return piece.lane_ids[0]
        return f"{edge_id}_{index}"

    def lane_neighbour(self, index: int, side: str) -> int | None:
        """The lane to the ``side`` ("left"/"right") of lane ``index``, or None at the road edge."""
        position = self.left_to_right.index(index) + (-1 if side == "left" else 1)
        return self.left_to_right[position] if 0 <= position < self.lane_count else None

    # --- positions -----------------------------------------------------------------------------------
    def span(self, lane_id: str) -> LaneSpan | None:
        return self.spans.get(lane_id)

    def lane_s(self, lane_id: str, sumo_pos_m: float) -> tuple[int, float] | None:
        """(road lane index, arc length on its path) of a SUMO lane position, or None if not on this road."""
        span = self.spans.get(lane_id)
        if span is None:
            return None
        return span.road_lane_index, span.start_s_m + sumo_pos_m * span.geometry_factor

    def lane_s_to_road_s(self, index: int, lane_s_m: ArrayLike) -> NDArray[np.float64]:
        """Arc length on lane ``index``'s path -> arc length on the road reference line."""
        lane_s, ref_s = self._to_reference[index]
        return np.interp(lane_s_m, lane_s, ref_s)

    def lane_to_road_s(self, index: int, lane_s_m: float) -> float:
        """Scalar :meth:`lane_s_to_road_s` without NumPy call overhead (the per-vehicle hot path)."""
        lane_s, ref_s = self._to_reference_lists[index]
        i = bisect.bisect_right(lane_s, lane_s_m) - 1
        if i < 0:
            return ref_s[0] + (lane_s_m - lane_s[0])
        if i >= len(lane_s) - 1:
            return ref_s[-1] + (lane_s_m - lane_s[-1])
        f = (lane_s_m - lane_s[i]) / (lane_s[i + 1] - lane_s[i])
        return ref_s[i] + f * (ref_s[i + 1] - ref_s[i])

    def road_s(self, x_m: ArrayLike, y_m: ArrayLike) -> NDArray[np.float64]:
        """Arc length of the closest point of the road reference line (vectorised)."""
        x = np.atleast_1d(np.asarray(x_m, dtype=np.float64))
        y = np.atleast_1d(np.asarray(y_m, dtype=np.float64))
        return shapely.line_locate_point(self.reference.line, shapely.points(x, y))

    def lateral_from_reference(self, x_m: ArrayLike, y_m: ArrayLike) -> NDArray[np.float64]:
        """Signed distance from the road's centre line, positive to the left."""
        return self.reference.lateral_offset(x_m, y_m)

    def contains(self, x_m: float, y_m: float, margin_m: float = 0.0) -> bool:
        """Whether (x, y) lies on the carriageway (between its edges, within its length), +margin."""
        s = float(self.road_s(x_m, y_m)[0])
        if s <= 0.0 and self._beyond_end(x_m, y_m, 0.0) or s >= self.reference.length_m and self._beyond_end(
            x_m, y_m, self.reference.length_m
        ):
            return False
        return abs(float(self.lateral_from_reference(x_m, y_m)[0])) <= self.width_m / 2 + margin_m

    def _beyond_end(self, x_m: float, y_m: float, s_m: float) -> bool:
        point = self.reference.points_at([s_m])[0]
        tangent = self.reference.tangents_at([s_m])[0]
        along = tangent[0] * (x_m - point[0]) + tangent[1] * (y_m - point[1])
        return along < -1e-6 if s_m == 0.0 else along > 1e-6

    def nearest_lane(self, x_m: float, y_m: float) -> int:
        """The lane whose centre line is closest to (x, y)."""
        point = shapely.Point(x_m, y_m)
        return int(np.argmin([path.line.distance(point) for path in self.lane_paths]))

    def pose_on_lane(self, lane_id: str, sumo_pos_m: float) -> tuple[float, float, float]:
        """(x, y, heading_rad) of a SUMO lane position on this road."""
        located = self.lane_s(lane_id, sumo_pos_m)
        if located is None:
            raise NetworkError(f"lane {lane_id!r} is not on the road {list(self.edge_ids)}")
        index, s = located
        path = self.lane_paths[index]
        point = path.points_at([s])[0]
        tangent = path.tangents_at([s])[0]
        return float(point[0]), float(point[1]), math.atan2(tangent[1], tangent[0])

    def __repr__(self) -> str:
        return (
            f"Road(edges={list(self.edge_ids)}, lanes={self.lane_count}, length_m={self.reference.length_m:.1f},"
            f" lefthand={self.lefthand})"
        )


class RoadNetwork:
    """A SUMO ``.net.xml`` read with sumolib (internal lanes included)."""

    def __init__(self, net_file: str | Path) -> None:
        self.path = Path(net_file)
        if not self.path.is_file():
            raise NetworkError(f"network file not found: {self.path}")
        try:
            self.net = sumolib.net.readNet(str(self.path), withInternal=True)
        except (xml.sax.SAXException, ValueError, KeyError, IndexError, TypeError) as error:
            raise NetworkError(f"malformed network file {self.path}: {error}") from error
        if not self.net.getEdges(withInternal=False):
            raise NetworkError(f"network file {self.path} has no edges (is it a SUMO .net.xml?)")
        self.lefthand = _declares_lefthand(self.path)
        self._roads: dict[tuple[str, ...], Road] = {}

    def edge(self, edge_id: str):
        try:
            return self.net.getEdge(edge_id)
        except KeyError:
            known = sorted(e.getID() for e in self.net.getEdges(withInternal=False))
            raise NetworkError(f"{self.path.name}: no edge {edge_id!r} (edges: {known})") from None

    def chain_from(self, edge_id: str) -> tuple[str, ...]:
        """The edges from ``edge_id`` onwards while each has exactly one successor (a road without forks)."""
        chain = [self.edge(edge_id)]
        while True:
            successors = [e for e in chain[-1].getOutgoing() if e.getFunction() != "internal"]
            if len(successors) != 1 or successors[0] in chain:
                break
            chain.append(successors[0])
        return tuple(e.getID() for e in chain)

    def road(self, edge_ids: tuple[str, ...] | list[str] | str | Any) -> Road:
        """The road through ``edge_ids``: a single edge id means that edge and its unique successors; a list the
        edges in order (connected); a ``RouteEnds`` (the config's) the route SUMO's router finds. Parallel lanes that continue
        make a carriageway of lanes; otherwise (turns, lane counts that change) one path along the route."""
        where = f"{self.path.name}: road"
        try:
            if hasattr(edge_ids, "from_edge"):  # the config's RouteEnds
                stops = (edge_ids.from_edge, *edge_ids.via, edge_ids.to_edge)
                ids = stops[:1]
                for here, there in zip(stops, stops[1:]):
                    ids += find_route(self.net, here, there, where)[1:]
                if len(set(ids)) != len(ids):
                    repeated = sorted({e for e in ids if ids.count(e) > 1})
                    raise RouteError(f"{where}: the route through {list(stops)} drives edges {repeated} twice")
            elif isinstance(edge_ids, str):
                ids = self.chain_from(edge_ids)
            else:
                ids = connected_route(self.net, tuple(edge_ids), where)
        except RouteError as error:
            raise NetworkError(str(error)) from None
        if ids not in self._roads:
            try:
                self._roads[ids] = Road(self, ids)
            except NetworkError:
                try:
                    self._roads[ids] = Road(self, ids, [lane_chain(self.net, ids)])
                except RouteError as error:
                    raise NetworkError(f"{where} {list(ids)}: {error}") from None
        return self._roads[ids]


def _declares_lefthand(path: Path) -> bool:
    """Whether the net's root element says lefthand="true" (netconvert --lefthand)."""
    import xml.etree.ElementTree as ElementTree

    for _, element in ElementTree.iterparse(path, events=("start",)):
        return element.get("lefthand", "false").lower() == "true"
    return False
