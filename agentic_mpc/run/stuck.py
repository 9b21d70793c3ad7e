"""When the ego is stuck: standing still although its specification asks for motion, with nothing in front of
it that it is merely queueing behind.

A step counts as stuck when the ego's speed is below :data:`STANDING_MPS`, the tracked reference speed is
above it, and either nothing stands directly ahead (in its lane, or overlapping it sideways) within
:data:`QUEUE_GAP_M` (the road ahead is free: the controller keeps it still), or what stands there is a static
obstacle within :data:`OBSTACLE_GAP_M` (a stopped car the ego must go around, not a queue that will move).
Standing behind a vehicle of the traffic is queueing, not stuck.
:class:`StuckTracker` keeps the stuck intervals; ``summary.csv`` has the longest (``stuck_s``) and the count
of static obstacles the ego got past (``blockages_passed``), ``events.csv`` one ``stuck`` row per interval
of at least :data:`REPORTED_S`. :func:`resume_to_v_ref_s` says how long the ego took to get back to speed
after it was last told to move on from a stop (``resume_to_v_ref_s`` in ``summary.csv``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from agentic_mpc.world.observation import Observation

STANDING_MPS = 0.1
"""Slower than this the ego stands."""
QUEUE_GAP_M = 8.0
"""A road user closer than this ahead in the ego's lane is what the ego waits behind (a standstill gap plus
slack: J0 stops 2 m behind a leader, the controller's queue distance a few metres more)."""
OBSTACLE_GAP_M = 25.0
"""A static obstacle closer than this ahead in the ego's lane is what a standing ego is stuck behind (J0 keeps
about 10 m of room to pull out behind one, plus slack)."""
REPORTED_S = 2.0
"""A stuck interval at least this long becomes a ``stuck`` event."""
HOPELESS_S = 10.0
"""Stuck this long behind obstacles that block every lane of the road: the run ends, saying so."""
RESUMED_BAND_MPS = 0.5
"""Back at v_ref: within this of it."""
RESUME_DECIDED_S = 15.0
"""A resume the run ends less than this after, short of v_ref, is undecided (NaN), not a miss: from a standstill J1's
ramp alone takes 5 s to 15 m/s (``traffic_ambulance_dense`` seed 2206 was asked to resume 3 s before its end)."""
JUNCTION_LINE_M = 12.0
"""Standing this close before a junction's line where it must stop or give way is waiting, not being stuck."""
BLOCKAGE_SPAN_M = 15.0
"""Obstacles within this distance of each other along the road block the road together."""


@dataclass(frozen=True)
class StuckInterval:
    start_s: float
    end_s: float
    reason: str
    """``road ahead free`` or ``behind obstacle <id>``."""
    road_s_m: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


@dataclass
class StuckTracker:
    """Feed it every step (:meth:`update`); :attr:`intervals` are the stuck ones, the last closed by
    :meth:`finish`."""

    lane_count: int | None = None
    """Lanes of the road, to tell a blockage of every lane (None: never)."""
    intervals: list[StuckInterval] = field(default_factory=list)
    _open: tuple[float, str, float] | None = None
    _last_time_s: float = math.nan
    _step_s: float = 0.0

    def update(self, observation: Observation, v_ref_mps: float) -> None:
        ego = observation.ego
        reason = None
        if ego.speed_mps < STANDING_MPS and math.isfinite(v_ref_mps) and v_ref_mps > STANDING_MPS:
            reason = _why_still(observation, self.lane_count)
        if self._open is not None and reason != self._open[1]:
            self._close(observation.time_s)
        if reason is not None and self._open is None:
            self._open = (observation.time_s, reason, ego.road_s_m)
        if math.isfinite(self._last_time_s):
            self._step_s = observation.time_s - self._last_time_s
        self._last_time_s = observation.time_s

    def finish(self) -> None:
        """Close the interval still open when the run ends (its last step counted whole)."""
        if self._open is not None:
            self._close(self._last_time_s + self._step_s)

    def _close(self, end_s: float) -> None:
        start_s, reason, road_s_m = self._open
        self.intervals.append(StuckInterval(start_s, end_s, reason, road_s_m))
        self._open = None

    @property
    def longest_s(self) -> float:
        return max((i.duration_s for i in self.intervals), default=0.0)

    @property
    def longest_reason(self) -> str:
        """Why the ego stood still in its longest stuck interval ("" if it never did)."""
        return max(self.intervals, key=lambda i: i.duration_s).reason if self.intervals else ""

    @property
    def hopeless(self) -> bool:
        """Whether the ego has stood for :data:`HOPELESS_S` behind obstacles that block every lane."""
        if self._open is None:
            return False
        start_s, reason, _ = self._open
        return reason.startswith("every lane blocked") and self._last_time_s + self._step_s - start_s >= HOPELESS_S

    def events(self) -> list[dict[str, Any]]:
        """``events.csv`` rows: one per interval of at least :data:`REPORTED_S`."""
        return [
            {"event": "stuck", "sim_time_s": round(i.start_s, 3), "tau": None, "source": "metrics",
             "content": f"stood still for {i.duration_s:.1f} s with v_ref > 0 ({i.reason})",
             "result": {"duration_s": round(i.duration_s, 3), "reason": i.reason, "road_s_m": round(i.road_s_m, 2)}}
            for i in self.intervals if i.duration_s >= REPORTED_S
        ]


def _why_still(observation: Observation, lane_count: int | None) -> str | None:
    """Why a standing ego counts as stuck, or None when it is queueing behind traffic or held at a junction's line
    (a red or yellow light, giving way, a stop sign) or giving way at its waiting point inside."""
    for j in observation.junctions_ahead[:1]:
        if 0.0 <= j.distance_m <= JUNCTION_LINE_M and (j.signal in ("red", "yellow") or j.must_yield):
            return None
        if j.must_yield and j.wait_s_m is not None and 0.0 <= j.wait_s_m - (j.stop_s_m - j.distance_m) <= JUNCTION_LINE_M:
            return None  # giving way at its waiting point inside
    ahead = [(v.gap_m, "vehicle", v.id) for v in observation.traffic
             if v.relation == "ahead" and v.gap_m < QUEUE_GAP_M and _in_path(v, observation.ego)]
    ahead += [(o.gap_m, "obstacle", o.id) for o in observation.obstacles
              if o.relation == "ahead" and o.lane_index == observation.ego.lane_index and o.gap_m < OBSTACLE_GAP_M]
    if not ahead:
        return "road ahead free"
    _, kind, identifier = min(ahead)
    if kind != "obstacle":
        return None
    blocking = next(o for o in observation.obstacles if o.id == identifier)
    together = [o for o in observation.obstacles if abs(o.road_s_m - blocking.road_s_m) <= BLOCKAGE_SPAN_M]
    if lane_count is not None and len({o.lane_index for o in together}) >= lane_count:
        return f"every lane blocked ({', '.join(sorted(o.id for o in together))})"
    return f"behind obstacle {identifier}"


def _in_path(vehicle: Any, ego: Any) -> bool:
    """In the ego's lane, or its body overlapping the ego's sideways: an ego standing astride a lane line (4017: its
    centre 5 cm into the left lane, a car 0.5 m ahead of it in the centre lane) queues behind it too."""
    if vehicle.relative_lane == 0:
        return True
    heading = ego.heading_rad
    sideways_m = (vehicle.y_m - ego.y_m) * math.cos(heading) - (vehicle.x_m - ego.x_m) * math.sin(heading)
    return abs(sideways_m) < 0.5 * (vehicle.width_m + ego.width_m)


def resume_to_v_ref_s(time_s: Any, v_mps: Any, v_ref_mps: Any) -> float:
    """Seconds from the last resume (the reference speed rising from 0 to above it) until the ego's speed is
    within :data:`RESUMED_BAND_MPS` of the new reference; NaN without a resume or when the run ended less than
    :data:`RESUME_DECIDED_S` after it short of v_ref, inf if it never got there."""
    time_s, v_mps, v_ref_mps = (np.asarray(a, dtype=np.float64) for a in (time_s, v_mps, v_ref_mps))
    resumes = np.flatnonzero((v_ref_mps[1:] > STANDING_MPS) & (v_ref_mps[:-1] <= STANDING_MPS)) + 1
    if not len(resumes):
        return math.nan
    start = int(resumes[-1])
    back = np.flatnonzero(v_mps[start:] >= v_ref_mps[start:] - RESUMED_BAND_MPS)
    if len(back):
        return round(float(time_s[start + back[0]] - time_s[start]), 3)
    return math.inf if time_s[-1] - time_s[start] >= RESUME_DECIDED_S else math.nan
