"""What the tactics need of a world's road and ego (:class:`TacticalRoad`): lane centres, sizes, and where a point
lies along and across the road."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class TacticalRoad:
    """What the tactics need of a world's road and ego: the lanes' centre lines (each lane's offset left of the
    road's reference line, by lane index) and the sizes that make the discs J0 keeps the ego's centre out of."""

    lane_centres_m: tuple[float, ...]
    ego_length_m: float
    ego_width_m: float
    clearance_margin_m: float = 0.5
    max_discs_per_vehicle: int = 8
    range_ahead_m: float = 80.0
    speed_zones: tuple[tuple[float, float, float], ...] = ()
    """(start, end along the road, speed limit) of the route's stretches slower than the road's limit."""
    speed_limit_mps: float = math.inf
    """The road's limit: a zone's cap at or above it changes nothing (and is not reported)."""
    locate: Callable[[float, float, float], tuple[float, float]] | None = None
    """(x, y, an along-road guess) -> (along-road position, offset left of the road's reference line) of the
    nearest road point near the guess; None: the rules that need the road's shape (``wave_through``) are off."""
