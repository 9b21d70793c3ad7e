"""The road as the SUMO world's interface gives it: the lanes by role and the speed limit, a lane by index or role,
which lane a path is, the ego's offset from a lane (the :class:`~agentic_mpc.world.base.World` methods that read
the ego's road; the road changes when the ego takes another route)."""

from __future__ import annotations

from typing import Any

from agentic_mpc.geometry import LanePath
from agentic_mpc.sumo.network import NetworkError, Road, RoadNetwork
from agentic_mpc.world.base import WorldError
from agentic_mpc.world.lanes import RoadLanes


class RoadReadings:
    """Mixed into :class:`~agentic_mpc.sumo.world.SumoWorld` (which sets ``road``, ``network``, ``_lane_of_path``)."""

    road: Road
    network: RoadNetwork
    _lane_of_path: dict[int, tuple[Any, int | None]]

    def lanes(self) -> RoadLanes:
        """The road's lanes by role and its speed limit (the lowest on the road)."""
        lanes = {role: self.road.lane_paths[index] for role, index in self.road.lane_roles().items()}
        limit = self.road.speed_limit_mps
        first = self.network.edge(self.road.edge_ids[0]).getLanes()  # a lane cars may not use: a hard shoulder
        shoulder = next((i for i, lane in enumerate(first) if not lane.allows("passenger")), None)
        return RoadLanes(lanes, float(limit), self.road.lefthand, tuple(self.road.lane_paths),
                         tuple(self.road.left_to_right), shoulder)

    def lane(self, ref: int | str) -> tuple[str, LanePath]:
        try:
            index = self.road.lane_index(ref)
        except NetworkError as error:
            raise WorldError(str(error)) from error
        return self.road.lane_role(index), self.road.lane_paths[index]

    def lane_index_of(self, path: LanePath | None) -> int | None:
        if path is None:
            return None
        cached = self._lane_of_path.get(id(path))
        if cached is None or cached[0] is not path:  # ids are reused after garbage collection
            lane = next((i for i, p in enumerate(self.road.lane_paths) if p is path or p == path), None)
            cached = self._lane_of_path[id(path)] = (path, lane)
        return cached[1]

    def lateral_offset_m(self, lane_index: int, x_m: float, y_m: float) -> float:
        return float(self.road.lane_paths[lane_index].lateral_offset(x_m, y_m)[0])
