"""The SUMO network around a run, for the replay and the figures: the lanes of the streets near the ego's path
(centre line and width), the lines between neighbouring lanes of a street, and the junctions' shapes.

Read from ``scenario.json``'s network file with sumolib (no simulation) and clipped to a region (the replay: 150 m
around the ego's path). What the ego's road draws itself is left out: on a carriageway (the paper's roads) its
lanes and the joints between its edges, so those runs look as they did; on a route through junctions every street
is drawn (the route is one lane of its streets) and the route over it. Only lanes cars may use (passenger or bus):
sidewalks, cycle paths and rails are not drawn. No matplotlib here (the replay page draws in the browser).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cached_property
from itertools import pairwise
from typing import Any

import numpy as np
import shapely

SIMPLIFY_M = 0.2
"""How far a simplified line may stray from the network's shape (the replay keeps its file small)."""
MIN_JUNCTION_AREA_M2 = 0.5
"""Junction shapes smaller than this (a dead end's sliver) are not drawn."""


@dataclass(frozen=True)
class NetworkDrawing:
    """The network near a run: each lane as (width, centre line), the dividers between neighbouring lanes of an
    edge, the junctions' outlines (rings, the first point not repeated); all (n, 2) arrays in the net's x, y."""

    lanes: tuple[tuple[float, np.ndarray], ...] = ()
    dividers: tuple[np.ndarray, ...] = ()
    junctions: tuple[np.ndarray, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.lanes or self.junctions)

    @cached_property
    def surface_outlines(self) -> tuple[np.ndarray, ...]:
        """The paved area as outlines: each lane's strip (its centre line widened to its width) and each junction."""
        strips = []
        for width, line in self.lanes:
            strip = shapely.buffer(shapely.LineString(line), width / 2, cap_style="flat", quad_segs=2)
            strips += [np.asarray(part.exterior.coords)[:-1] for part in getattr(strip, "geoms", [strip])
                       if not part.is_empty]
        return tuple(strips) + self.junctions

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> NetworkDrawing:
        """The drawing back from :meth:`to_json`'s form (the replay's animation draws a scene's network)."""
        return cls(tuple((float(width), np.asarray(line, dtype=float)) for width, lines in data.get("lanes", [])
                         for line in lines),
                   tuple(np.asarray(line, dtype=float) for line in data.get("dividers", [])),
                   tuple(np.asarray(ring, dtype=float) for ring in data.get("junctions", [])))

    def to_json(self, digits: int = 1) -> dict[str, Any]:
        """The replay's form, to ``digits`` decimals (a decimetre is plenty to draw with): ``lanes`` as
        [width, [polyline, ...]] per width (0.1 m), ``dividers`` and ``junctions`` as lists of [[x, y], ...]."""
        by_width: dict[float, list[list[list[float]]]] = {}
        for width, line in self.lanes:
            by_width.setdefault(round(width, 1), []).append(_points(line, digits))
        return {"lanes": [[width, lines] for width, lines in sorted(by_width.items())],
                "dividers": [_points(line, digits) for line in self.dividers],
                "junctions": [_points(ring, digits) for ring in self.junctions]}


def _points(line: np.ndarray, digits: int) -> list[list[float]]:
    return [[round(float(x), digits), round(float(y), digits)] for x, y in line]


def _drives(lane: Any) -> bool:
    """Whether cars use ``lane`` (a sumolib lane): a street, not a sidewalk, a cycle path or a track."""
    return bool(lane.allows("passenger") or lane.allows("bus"))


def _parts(geometry: Any) -> list[Any]:
    """The non-empty simple parts of a shapely geometry (a clip may split a line or a polygon)."""
    parts = getattr(geometry, "geoms", [geometry])
    return [p for p in parts if not p.is_empty and p.geom_type in ("LineString", "Polygon")]


def _clipped_lines(coordinates: Any, region: Any) -> list[np.ndarray]:
    line = shapely.LineString(coordinates)
    if not region.intersects(line):
        return []
    return [np.asarray(shapely.simplify(part, SIMPLIFY_M).coords) for part in _parts(shapely.intersection(line, region))
            if part.length > 0.5]


def _divider(lane: Any, next_lane: Any) -> np.ndarray | None:
    """The line between two neighbouring lanes of an edge: ``lane``'s centre line moved half its width towards
    ``next_lane`` (SUMO numbers lanes from the right in right-hand nets, from the left in left-hand ones)."""
    from agentic_mpc.geometry import LanePath

    path = LanePath(lane.getShape())
    middle = np.asarray(next_lane.getShape())[len(next_lane.getShape()) // 2]
    side = 1.0 if float(path.lateral_offset(middle[0], middle[1])[0]) > 0.0 else -1.0
    try:
        return path.parallel(side * lane.getWidth() / 2).coordinates
    except ValueError:  # a lane too short or curled to move sideways: no divider drawn
        return None


def network_near(net: Any, region: Any, drawn_by_road: Iterable[str] = ()) -> NetworkDrawing:
    """The network ``net`` (a sumolib net) inside ``region`` (a shapely geometry), without the lanes in
    ``drawn_by_road`` (lane ids the road drawing shows) and the junctions that join only such lanes."""
    shapely.prepare(region)
    skip = frozenset(drawn_by_road)
    lanes: list[tuple[float, np.ndarray]] = []
    dividers: list[np.ndarray] = []
    for edge in net.getEdges(withInternal=False):
        own = [lane for lane in edge.getLanes() if _drives(lane)]
        if not own or all(lane.getID() in skip for lane in own):
            continue
        xmin, ymin, xmax, ymax = edge.getBoundingBox()
        if not region.intersects(shapely.box(xmin - 5.0, ymin - 5.0, xmax + 5.0, ymax + 5.0)):
            continue
        for lane in own:
            if lane.getID() not in skip:
                lanes += [(float(lane.getWidth()), line) for line in _clipped_lines(lane.getShape(), region)]
        ordered = sorted(own, key=lambda lane: lane.getIndex())
        for lane, next_lane in pairwise(ordered):
            divider = _divider(lane, next_lane) if next_lane.getIndex() == lane.getIndex() + 1 else None
            if divider is not None:
                dividers += _clipped_lines(divider, region)
    return NetworkDrawing(tuple(lanes), tuple(dividers), tuple(_junctions(net, region, skip)))


def _junctions(net: Any, region: Any, skip: frozenset[str]) -> list[np.ndarray]:
    rings = []
    for node in net.getNodes():
        shape = node.getShape()
        if len(shape) < 3:
            continue
        edges = [e for e in node.getIncoming() + node.getOutgoing() if e.getFunction() != "internal"]
        lanes = [lane.getID() for e in edges for lane in e.getLanes() if _drives(lane)]
        if not lanes or all(lane in skip for lane in lanes):
            continue  # a path's junction, or a joint of the ego's carriageway (its drawing covers it)
        polygon = shapely.Polygon(shape)
        if not polygon.is_valid:
            polygon = shapely.make_valid(polygon)
        if polygon.area < MIN_JUNCTION_AREA_M2 or not region.intersects(polygon):
            continue
        for part in _parts(shapely.intersection(polygon, region)):
            ring = np.asarray(shapely.simplify(part, SIMPLIFY_M).exterior.coords)[:-1]
            if len(ring) >= 3:
                rings.append(ring)
    return rings


def corridor(paths: Iterable[np.ndarray], margin_m: float) -> Any:
    """The region within ``margin_m`` of any of ``paths`` ((n, 2) arrays: the ego's tracks)."""
    shapes = [shapely.simplify(shapely.LineString(p), 1.0) if len(p) > 1 else shapely.Point(p[0])
              for p in paths if len(p)]
    if not shapes:
        return shapely.Polygon()
    return shapely.buffer(shapely.union_all(shapes), margin_m, quad_segs=4)


def sumo_network_near(simulation: Mapping[str, Any], region: Any) -> NetworkDrawing:
    """The network of a SUMO run (``scenario.json``'s ``simulation``) inside ``region``; on a carriageway without
    the road's own lanes and joints (:func:`agentic_mpc.plots.road.sumo_network_and_road`)."""
    from agentic_mpc.plots.road import sumo_network_and_road

    network, road = sumo_network_and_road(simulation)
    return network_near(network.net, region, () if road.is_route else road.spans)
