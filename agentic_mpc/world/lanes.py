"""The lanes of the ego's road, as every world gives them and the tools and the specification builder use them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

from agentic_mpc.geometry import LanePath


class RoadLanes(NamedTuple):
    """The ego road's lane centre lines by role ("center", "left", "right"; a road may have fewer), its speed
    limit, and which side traffic keeps to."""

    lanes: Mapping[str, LanePath]
    speed_limit_mps: float
    lefthand: bool = False
