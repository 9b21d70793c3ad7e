"""Collisions of the ego as they happen: footprint overlap, one record per contact episode, and its cause.

Every world reports contact in ``Observation.collisions`` (SUMO's own reports plus :func:`boxes_overlap` of the
ego's box with every other vehicle's and obstacle's box: SUMO does not see the part of the ego that sticks
into the next lane). A SUMO report counts only when the footprints confirm it (:func:`footprint_gap_m` within
:data:`CONTACT_TOLERANCE_M`): SUMO checks in lane coordinates, and on a curve they can be a metre off; the
others are kept as :class:`ReportWithoutContact`. :class:`CollisionTracker` turns the per-step reports into
contact EPISODES: an episode with one vehicle starts at the first step in contact and lasts until the two have
been apart for :data:`SEPARATION_S`; each episode is counted once and classified by :func:`classify` from the
recent observations (positions, lane indices, lateral offsets; lateral speeds from successive observations).

Causes and fault (the rule the metrics use, :data:`EGO_AT_FAULT`):

- ``ego_into_stopped``: the other is a static obstacle (or a vehicle that stood still for the whole
  history) -- ego at fault;
- ``ego_struck_leader``: lengthwise contact with the other ahead (the ego ran into it) -- ego at fault;
- ``rear_ended``: lengthwise contact with the other behind (it ran into the ego) -- not the ego's fault;
- ``struck_standing_ego``: lengthwise contact with the other ahead while the ego has stood for
  :data:`STANDING_BEFORE_S` and the other moves (a U-turning car's rear swinging into it) -- not the ego's fault;
- ``side_swipe_ego_lane_change`` / ``side_swipe_other_lane_change``: sideways contact, named after whose
  lateral motion brought the two together -- the ego's: at fault; the other's: not. Decided in this order:
  a lane change toward the other within the history (only one of them made one); else the larger lateral
  speed toward the other over the last :data:`LATERAL_WINDOW_S` (if at least :data:`LATERAL_SPEED_MPS`);
  else whoever's centre sits further off its lane's centre toward the other (ties: the ego, whose lateral
  position our controller chooses).

"Lengthwise" or "sideways" is the axis along which the boxes came together: in the ego's frame, at the last
observation before contact, they overlapped sideways but not lengthwise (then lengthwise contact) or the
other way round; when that does not decide (a turned box's corner), the one axis on which they closed in
since; failing that, the axis of smaller penetration now. ``rear_ended`` needs the follower in the ego's lane: one from a neighbour lane that clips the
ego's corner is a side swipe, decided as above (an ego sticking into that lane is at fault). A lengthwise
contact shortly after a cut-in is still ``rear_ended`` / ``ego_struck_leader``.

Pure geometry over observations: no SUMO, no numpy (the observation module imports this one).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any, Literal, Protocol


class Observation(Protocol):
    """What the collision tracker reads of an observation (``world/observation.py:Observation``, which imports
    this module: named here by its shape so that the two files do not import each other)."""

    time_s: float
    ego: Any
    obstacles: Sequence[Any]
    collisions: Sequence[Any]
    emergency_vehicles: Sequence[Any]

    def vehicle(self, vehicle_id: str) -> Any: ...

Cause = Literal["rear_ended", "ego_struck_leader", "side_swipe_ego_lane_change", "side_swipe_other_lane_change",
                "ego_into_stopped", "struck_standing_ego"]
EGO_AT_FAULT: frozenset[str] = frozenset({"ego_struck_leader", "side_swipe_ego_lane_change", "ego_into_stopped"})
"""The causes that put the ego at fault: it struck, it moved sideways into the other, it hit something still."""

HISTORY_S = 2.0
"""How far back a lane change toward the other counts (a SUMO lane change without sublane is instant)."""
LATERAL_WINDOW_S = 0.5
"""Lateral speeds are averaged over this last stretch before contact (recent motion, not an old drift)."""
LATERAL_SPEED_MPS = 0.1
"""Below this both count as driving straight (the controller's lateral jitter is a few cm/s)."""
CONTACT_TOLERANCE_M = 0.1
"""A collision SUMO reports is contact only when the two footprints come within this distance. SUMO checks in
lane coordinates, and on a curve those place a car on the next lane up to a metre away from where it is:
measured on the curved road, reports with the boxes 0.5-1.9 m apart (docs/traffic.md). Two samples 40 ms
apart can straddle a glancing touch; 0.1 m leaves room for that."""
SEPARATION_S = 0.5
"""Apart for this long ends an episode: a one-step flicker of the overlap is not a second collision."""
STOPPED_MPS = 0.1
STANDING_BEFORE_S = 0.2
"""Standing this long before a lengthwise contact with a car ahead (five steps of 0.04 s), the ego did not close
the gap: the other did."""


class Footprint(Protocol):
    """A rectangle: centre, heading (radians from +x) and size; every observation type has these."""

    @property
    def x_m(self) -> float: ...
    @property
    def y_m(self) -> float: ...
    @property
    def heading_rad(self) -> float: ...
    @property
    def length_m(self) -> float: ...
    @property
    def width_m(self) -> float: ...


def corners(x: float, y: float, heading: float, length: float, width: float) -> list[tuple[float, float]]:
    c, s = math.cos(heading), math.sin(heading)
    hl, hw = 0.5 * length, 0.5 * width
    return [(x + c * a - s * b, y + s * a + c * b) for a, b in ((hl, hw), (hl, -hw), (-hl, -hw), (-hl, hw))]


def boxes_overlap(a: Footprint, b: Footprint) -> bool:
    """Separating-axis test of two oriented rectangles; touching counts as contact.

    On each of the four edge directions the two boxes' projections are apart when the centres' distance along
    it exceeds the sum of the half extents (a box's half extent along a direction at angle t to its heading:
    half length |cos t| + half width |sin t|). Closed form: it runs for every near vehicle every step."""
    dx, dy = b.x_m - a.x_m, b.y_m - a.y_m
    reach = 0.5 * (math.hypot(a.length_m, a.width_m) + math.hypot(b.length_m, b.width_m))
    if dx * dx + dy * dy > reach * reach:
        return False
    ca, sa, cb, sb = math.cos(a.heading_rad), math.sin(a.heading_rad), math.cos(b.heading_rad), math.sin(b.heading_rad)
    cos_ab, sin_ab = abs(ca * cb + sa * sb), abs(ca * sb - sa * cb)  # of the angle between the headings
    la, wa, lb, wb = 0.5 * a.length_m, 0.5 * a.width_m, 0.5 * b.length_m, 0.5 * b.width_m
    return not (abs(dx * ca + dy * sa) > la + lb * cos_ab + wb * sin_ab
                or abs(dy * ca - dx * sa) > wa + lb * sin_ab + wb * cos_ab
                or abs(dx * cb + dy * sb) > lb + la * cos_ab + wa * sin_ab
                or abs(dy * cb - dx * sb) > wb + la * sin_ab + wa * cos_ab)


def _point_to_segment_m(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    abx, aby = b[0] - a[0], b[1] - a[1]
    t = ((p[0] - a[0]) * abx + (p[1] - a[1]) * aby) / (abx * abx + aby * aby)
    t = min(1.0, max(0.0, t))
    return math.hypot(p[0] - a[0] - t * abx, p[1] - a[1] - t * aby)


def footprint_gap_m(a: Footprint, b: Footprint) -> float:
    """The shortest distance between two oriented rectangles; 0 when they overlap or touch."""
    if boxes_overlap(a, b):
        return 0.0
    ca = corners(a.x_m, a.y_m, a.heading_rad, a.length_m, a.width_m)
    cb = corners(b.x_m, b.y_m, b.heading_rad, b.length_m, b.width_m)
    # Apart convex polygons: the nearest points are a corner of one and an edge of the other.
    return min(_point_to_segment_m(p, box[n - 1], box[n])
               for points, box in ((ca, cb), (cb, ca)) for p in points for n in range(4))


def in_ego_frame(ego: Footprint, other: Footprint) -> tuple[float, float]:
    """(ahead, to the left) of the other's centre from the ego's centre, along the ego's heading (m)."""
    dx, dy = other.x_m - ego.x_m, other.y_m - ego.y_m
    c, s = math.cos(ego.heading_rad), math.sin(ego.heading_rad)
    return dx * c + dy * s, -dx * s + dy * c


def _penetration(ego: Footprint, other: Footprint) -> tuple[float, float]:
    """(lengthwise, sideways) overlap of the two boxes in the ego's frame (negative: apart on that axis)."""
    ahead, left = in_ego_frame(ego, other)
    return 0.5 * (ego.length_m + other.length_m) - abs(ahead), 0.5 * (ego.width_m + other.width_m) - abs(left)


def contact_axis(before: tuple[Footprint, Footprint] | None, now: tuple[Footprint, Footprint]) -> str:
    """"lengthwise" or "sideways": the axis along which the boxes came together (see the module docstring)."""
    lengthwise, sideways = _penetration(*now)
    if before is not None:
        was_lengthwise, was_sideways = _penetration(*before)
        if was_sideways > 0.0 >= was_lengthwise:
            return "lengthwise"
        if was_lengthwise > 0.0 >= was_sideways:
            return "sideways"
        # Undecided in the ego's frame (a turned box's corner): the axis on which they closed in. Measured in
        # SUMO: an ego turning in behind a faster car clipped its rear corner while the car pulled away.
        closed_lengthwise, closed_sideways = lengthwise > was_lengthwise, sideways > was_sideways
        if closed_lengthwise != closed_sideways:
            return "lengthwise" if closed_lengthwise else "sideways"
    return "lengthwise" if lengthwise <= sideways else "sideways"


@dataclass(frozen=True, slots=True)
class Sighting:
    """One party at one observation: what the cause needs."""

    time_s: float
    lane_index: int
    lateral_offset_m: float
    """From its lane's centre line, positive to the left."""
    speed_mps: float
    relative_lane: int | None
    """The other's lane relative to the ego's (the same value in both parties' sightings)."""


def lateral_speed_mps(track: Sequence[Sighting], since_s: float) -> float:
    """Mean rate of change of the lateral offset (+ left) over successive sightings after ``since_s`` in the
    same lane (a lane change makes the offset jump by a lane width: that pair is left out)."""
    rates = [(b.lateral_offset_m - a.lateral_offset_m) / (b.time_s - a.time_s)
             for a, b in pairwise(track)
             if b.time_s > since_s and a.lane_index == b.lane_index and b.time_s > a.time_s]
    return sum(rates) / len(rates) if rates else 0.0


def lane_changes_toward(ego: Sequence[Sighting], other: Sequence[Sighting]) -> tuple[bool, bool]:
    """(the ego, the other) changed lane toward the other party within the sightings: a step where the other's
    relative lane came closer to 0 while that party's (and only that party's) lane index changed."""
    ego_moved = other_moved = False
    for (e0, o0), (e1, o1) in pairwise(zip(ego, other, strict=True)):
        if o0.relative_lane is None or o1.relative_lane is None or abs(o1.relative_lane) >= abs(o0.relative_lane):
            continue
        ego_changed, other_changed = e0.lane_index != e1.lane_index, o0.lane_index != o1.lane_index
        ego_moved |= ego_changed and not other_changed
        other_moved |= other_changed and not ego_changed
    return ego_moved, other_moved


def _side_swipe(ego: Sequence[Sighting], other: Sequence[Sighting], other_is_left: bool) -> Cause:
    ego_changed, other_changed = lane_changes_toward(ego, other)
    if ego_changed != other_changed:
        return "side_swipe_ego_lane_change" if ego_changed else "side_swipe_other_lane_change"
    side = 1.0 if other_is_left else -1.0  # +: toward the other from the ego's point of view
    since = ego[-1].time_s - LATERAL_WINDOW_S - 1e-9
    ego_toward = side * lateral_speed_mps(ego, since)
    other_toward = -side * lateral_speed_mps(other, since)
    if max(ego_toward, other_toward) >= LATERAL_SPEED_MPS:
        return "side_swipe_ego_lane_change" if ego_toward >= other_toward else "side_swipe_other_lane_change"
    # Both straight: whoever sits further over toward the other (the ego's offset, the other's mirrored).
    ego_over, other_over = side * ego[-1].lateral_offset_m, -side * other[-1].lateral_offset_m
    return "side_swipe_ego_lane_change" if ego_over >= other_over else "side_swipe_other_lane_change"


def classify(history: Sequence[Observation], other_id: str) -> Cause:
    """The cause of a contact between the ego and ``other_id`` in ``history[-1]``; ``history``: the recent
    observations, oldest first (see the module docstring for the rules)."""
    now = history[-1]
    if any(o.id == other_id for o in now.obstacles):
        return "ego_into_stopped"
    ego_track: list[Sighting] = []
    other_track: list[Sighting] = []
    poses: list[tuple[Footprint, Footprint]] = []
    for observation in history:
        other = observation.vehicle(other_id) or next(
            (e.vehicle for e in observation.emergency_vehicles if e.vehicle.id == other_id), None)
        if other is None:
            continue
        ego = observation.ego
        ego_track.append(Sighting(observation.time_s, ego.lane_index, ego.lateral_offset_m, ego.speed_mps,
                                  other.relative_lane))
        other_track.append(Sighting(observation.time_s, other.lane_index, other.lateral_offset_m, other.speed_mps,
                                    other.relative_lane))
        poses.append((ego, other))
    if not poses or poses[-1][0] is not now.ego:
        # Reported (by SUMO) but not seen: SUMO's collider is the one that drove into the other.
        ego_collider = any(c.collider == now.ego.id and c.victim == other_id for c in now.collisions)
        return "ego_struck_leader" if ego_collider else "rear_ended"
    if all(s.speed_mps < STOPPED_MPS for s in other_track) and now.ego.speed_mps >= STOPPED_MPS:
        return "ego_into_stopped"
    axis = contact_axis(poses[-2] if len(poses) > 1 else None, poses[-1])
    ahead, left = in_ego_frame(*poses[-1])
    if axis == "lengthwise" and (ahead > 0.0 or other_track[-1].relative_lane in (0, None)):
        if ahead > 0.0 and other_track[-1].speed_mps >= STOPPED_MPS and all(
                s.speed_mps < STOPPED_MPS for s in ego_track if s.time_s >= now.time_s - STANDING_BEFORE_S):
            return "struck_standing_ego"  # (the ego stood: the one ahead came to it)
        return "ego_struck_leader" if ahead > 0.0 else "rear_ended"
    return _side_swipe(ego_track, other_track, other_is_left=left > 0.0)


@dataclass(frozen=True, slots=True)
class CollisionEpisode:
    """One contact episode of the ego with one other road user, as it started."""

    time_s: float
    other_id: str
    other_type: str
    cause: Cause
    source: str
    """"sumo" (SUMO reported it first) or "geometry" (our box overlap)."""
    ego_speed_mps: float
    other_speed_mps: float

    @property
    def ego_at_fault(self) -> bool:
        return self.cause in EGO_AT_FAULT


@dataclass
class ReportWithoutContact:
    """SUMO reported the ego colliding with ``other_id``, but the footprints never came within
    :data:`CONTACT_TOLERANCE_M` of each other while it went on reporting it: not a collision, kept for the record."""

    time_s: float
    other_id: str
    other_type: str
    min_gap_m: float
    """The closest the two footprints came during the reports."""
    last_s: float


@dataclass
class CollisionTracker:
    """Feed it every observation in order (:meth:`update`); it keeps :attr:`episodes`, one per contact episode,
    and :attr:`reports_without_contact`, SUMO's reports that our footprints do not confirm (an episode each)."""

    history_s: float = HISTORY_S
    separation_s: float = SEPARATION_S
    episodes: list[CollisionEpisode] = field(default_factory=list)
    reports_without_contact: list[ReportWithoutContact] = field(default_factory=list)
    _history: deque[Observation] = field(default_factory=deque)
    _last_contact_s: dict[str, float] = field(default_factory=dict)
    _open_reports: dict[str, ReportWithoutContact] = field(default_factory=dict)

    def _report_without_contact(self, time_s: float, other_id: str, other_type: str, gap_m: float) -> None:
        report = self._open_reports.get(other_id)
        if report is None or time_s - report.last_s > self.separation_s + 1e-9:
            report = self._open_reports[other_id] = ReportWithoutContact(time_s, other_id, other_type, gap_m, time_s)
            self.reports_without_contact.append(report)
        report.min_gap_m, report.last_s = min(report.min_gap_m, gap_m), time_s

    def update(self, observation: Observation) -> list[CollisionEpisode]:
        """Record ``observation``; returns the episodes that start in it."""
        history = self._history
        history.append(observation)
        while history and history[0].time_s < observation.time_s - self.history_s - 1e-9:
            history.popleft()
        ego_id = observation.ego.id
        started = []
        for report in observation.collisions:
            if not report.involves_ego:
                continue
            other_id = report.victim if report.collider == ego_id else report.collider
            ego_is_collider = report.collider == ego_id
            if not report.ego_contact:
                self._report_without_contact(observation.time_s, other_id,
                                             report.victim_type if ego_is_collider else report.collider_type,
                                             report.footprint_gap_m)
                continue
            last = self._last_contact_s.get(other_id)
            self._last_contact_s[other_id] = observation.time_s
            if last is not None and observation.time_s - last <= self.separation_s + 1e-9:
                continue  # the same episode goes on
            open_report = self._open_reports.pop(other_id, None)
            if open_report is not None and observation.time_s - open_report.last_s <= self.separation_s + 1e-9:
                self.reports_without_contact.remove(open_report)  # it was the start of this contact
            episode = CollisionEpisode(
                observation.time_s, other_id, report.victim_type if ego_is_collider else report.collider_type,
                classify(history, other_id), report.source,
                observation.ego.speed_mps,
                report.victim_speed_mps if ego_is_collider else report.collider_speed_mps,
            )
            self.episodes.append(episode)
            started.append(episode)
        return started

    @property
    def at_fault(self) -> int:
        return sum(1 for e in self.episodes if e.ego_at_fault)
