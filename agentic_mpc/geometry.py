"""Lane paths: a shapely polyline with exact arc length, projection and reference points.

A lane is a polyline (SUMO lane shapes are polylines too), so arc length along it is exact and curves are as
fine as their vertices. Points beyond either end are clamped to the end: the end of a path is where a
tracking reference stops.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LineString


class PathError(ValueError):
    """A path that cannot be a lane: fewer than two distinct points, non-finite coordinates, zero length."""


class LanePath:
    """An immutable lane centre line with arc-length parametrisation.

    ``arc_length_m`` is the polyline's cumulative length at each vertex; ``points_at`` and ``tangents_at``
    interpolate by arc length, which is what the paper's reference-point definition integrates.
    """

    __slots__ = ("_line", "_xy", "_s", "_unit_tangents", "name")

    def __init__(self, coordinates: ArrayLike | LineString, name: str = "") -> None:
        xy = np.asarray(
            coordinates.coords if isinstance(coordinates, LineString) else coordinates, dtype=np.float64
        )
        if xy.ndim != 2 or xy.shape[1] != 2:
            raise PathError(f"path {name!r}: expected (N, 2) coordinates, got shape {xy.shape}")
        if not np.all(np.isfinite(xy)):
            raise PathError(f"path {name!r}: coordinates must be finite")
        # Consecutive duplicates give zero-length segments with no tangent.
        keep = np.ones(len(xy), dtype=bool)
        keep[1:] = np.any(np.diff(xy, axis=0) != 0.0, axis=1)
        xy = xy[keep]
        if len(xy) < 2:
            raise PathError(f"path {name!r}: needs at least two distinct points, got {len(xy)}")
        segments = np.diff(xy, axis=0)
        lengths = np.hypot(segments[:, 0], segments[:, 1])
        self._xy = xy
        self._xy.setflags(write=False)
        self._s = np.concatenate([[0.0], np.cumsum(lengths)])
        self._s.setflags(write=False)
        self._unit_tangents = segments / lengths[:, None]
        self._line = LineString(xy)
        self.name = name

    @classmethod
    def straight(cls, start_xy: Sequence[float], end_xy: Sequence[float], name: str = "") -> LanePath:
        return cls([start_xy, end_xy], name=name)

    @property
    def line(self) -> LineString:
        return self._line

    @property
    def coordinates(self) -> NDArray[np.float64]:
        return self._xy

    @property
    def arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(vertices (N, 2), arc length at each vertex (N,), unit tangent of each segment (N-1, 2)), for
        compiled code that walks the polyline (``primitives/reference_kernel.py``)."""
        return self._xy, self._s, self._unit_tangents

    @property
    def length_m(self) -> float:
        return float(self._s[-1])

    def project(self, x_m: float, y_m: float) -> float:
        """Arc length of the point of the path closest to (x, y): the paper's tau_0."""
        return float(shapely.line_locate_point(self._line, shapely.Point(x_m, y_m)))

    def _locate(self, s_m: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Arc lengths clamped to the path, and the segment each falls on."""
        s = np.minimum(np.maximum(np.asarray(s_m, dtype=np.float64), 0.0), self._s[-1])
        i = np.searchsorted(self._s, s, side="right") - 1
        return s, np.minimum(np.maximum(i, 0), len(self._s) - 2)

    def points_at(self, s_m: ArrayLike) -> NDArray[np.float64]:
        """Points at arc lengths ``s_m`` (clamped to the path), shape (n, 2)."""
        return self.points_and_tangents_at(s_m)[0]

    def tangents_at(self, s_m: ArrayLike) -> NDArray[np.float64]:
        """Unit tangents (direction of travel) at arc lengths ``s_m``, shape (n, 2)."""
        return self._unit_tangents[self._locate(s_m)[1]]

    def points_and_tangents_at(self, s_m: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points and unit tangents at arc lengths ``s_m`` in one pass (the controller calls this every step)."""
        s, i = self._locate(s_m)
        tangents = self._unit_tangents[i]
        return self._xy[i] + (s - self._s[i])[:, None] * tangents, tangents

    def reference_points(
        self, x_m: float, y_m: float, v_ref_mps: float, dt_s: float, horizon: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The paper's J1 reference: points k = 1..H spaced v_ref*dt apart by arc length from the closest
        point. Returns (points (H, 2), unit tangents (H, 2))."""
        return self.points_and_tangents_at(self.project(x_m, y_m) + v_ref_mps * dt_s * np.arange(1, horizon + 1))

    def lateral_offset(self, x_m: ArrayLike, y_m: ArrayLike) -> NDArray[np.float64]:
        """Signed distance from the path, positive to the LEFT of the direction of travel."""
        x = np.atleast_1d(np.asarray(x_m, dtype=np.float64))
        y = np.atleast_1d(np.asarray(y_m, dtype=np.float64))
        s = shapely.line_locate_point(self._line, shapely.points(x, y))
        foot, tangent = self.points_and_tangents_at(s)
        return tangent[:, 0] * (y - foot[:, 1]) - tangent[:, 1] * (x - foot[:, 0])

    def parallel(self, offset_left_m: float, name: str = "") -> LanePath:
        """The path shifted sideways, positive to the left (a neighbouring lane)."""
        shifted = shapely.offset_curve(self._line, offset_left_m, join_style="mitre")
        if not isinstance(shifted, LineString):  # a turn tighter than the offset: shapely's result falls apart
            shifted = self._xy + offset_left_m * self._vertex_normals()
        return LanePath(shifted, name=name or f"{self.name}{offset_left_m:+.2f}m")

    def _vertex_normals(self) -> NDArray[np.float64]:
        """Unit left normals at the vertices (the mean direction of the two segments at each)."""
        tangents = self._unit_tangents
        at_vertices = np.vstack([tangents[:1], tangents[:-1] + tangents[1:], tangents[-1:]])
        at_vertices /= np.maximum(np.hypot(at_vertices[:, 0], at_vertices[:, 1]), 1e-9)[:, None]
        return np.column_stack([-at_vertices[:, 1], at_vertices[:, 0]])

    def __repr__(self) -> str:
        return f"LanePath(name={self.name!r}, vertices={len(self._xy)}, length_m={self.length_m:.1f})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, LanePath) and np.array_equal(self._xy, other._xy)

    def __hash__(self) -> int:
        return hash(self._xy.tobytes())
