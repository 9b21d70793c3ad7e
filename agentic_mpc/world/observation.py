"""What the ego perceives at one step: the one observation type every world produces.

The SUMO world and the plain-Python world build it; the controller's surroundings, the metrics, the MCP
resources and the agent's observation messages read it. This module imports nothing of SUMO.

Coordinates are the world's (metres), positions are vehicle CENTRES, headings are radians from +x
counter-clockwise. Along-road quantities are measured on the road's centre line:

- ``offset_m``: centre-to-centre distance along the road, positive when the other vehicle is ahead;
- ``gap_m``: bumper-to-bumper clearance along the road (``|offset| - (length + ego length) / 2``);
  negative when the two overlap lengthwise, i.e. drive alongside;
- ``relation``: "ahead", "behind" or "alongside" (lengthwise overlap);
- ``relative_lane``: lanes to the left of the ego's lane (+1 = one lane left, -1 = one lane right);
- ``closing_speed_mps``: how fast the gap shrinks (positive = approaching).

``Observation.to_json()`` is the stable, JSON-ready form (MCP resources, observation messages): a dict with
exactly the keys ``time_s``, ``ego``, ``traffic``, ``emergency_vehicles``, ``obstacles``, ``collisions``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Literal, TypeVar

from agentic_mpc.world.collisions import CONTACT_TOLERANCE_M, boxes_overlap, corners  # noqa: F401 (re-exported)

Relation = Literal["ahead", "behind", "alongside"]

JSON_KEYS = ("time_s", "ego", "traffic", "emergency_vehicles", "obstacles", "collisions")


_Record = TypeVar("_Record")


def _fast_init(cls: type[_Record]) -> type[_Record]:
    """Give a frozen, slotted dataclass an ``__init__`` that writes its slots through their descriptors.

    The generated one goes through ``object.__setattr__`` field by field; the SUMO world builds one
    observation per vehicle in range every step, and this halves its cost (22 fields: 6 -> 3 us on the
    project machine). Same signature (no defaults, no ``__post_init__`` in these classes), same result.
    """
    names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    namespace = {f"_set_{name}": cls.__dict__[name].__set__ for name in names}
    body = "".join(f"    _set_{name}(self, {name})\n" for name in names)
    exec(f"def __init__(self, {', '.join(names)}):\n{body}", namespace)  # noqa: S102 (built from field names)
    init = namespace["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    cls.__init__ = init  # type: ignore[misc]
    return cls


def _rounded(record: Any, digits: int = 3) -> dict[str, Any]:
    out = {}
    for key, value in asdict(record).items():
        if isinstance(value, float):
            value = round(value, digits) if math.isfinite(value) else None
        out[key] = value
    return out


@_fast_init
@dataclass(frozen=True, slots=True)
class EgoObservation:
    """The ego as the world sees it (SUMO: where our model put it, converted to the centre)."""

    id: str
    x_m: float
    y_m: float
    heading_rad: float
    speed_mps: float
    """SUMO's speed: the distance the ego was moved in the last step divided by the step length."""
    lane_id: str
    """'' when the ego is off every lane (then SUMO traffic ignores it)."""
    lane_index: int
    lane_role: str
    """"left"/"center"/"right" (or "lane<i>"; "" off the road)."""
    edge_id: str
    road_s_m: float
    lateral_offset_m: float
    """Signed distance of the centre from the centre line of ``lane_id`` (positive to the left); off the
    road, from the road's centre line."""
    length_m: float
    width_m: float

    def to_json(self) -> dict[str, Any]:
        return _rounded(self)


@_fast_init
@dataclass(frozen=True, slots=True)
class VehicleObservation:
    """Another road user near the ego."""

    id: str
    type_id: str
    vclass: str
    x_m: float
    y_m: float
    heading_rad: float
    speed_mps: float
    vx_mps: float
    vy_mps: float
    lane_id: str
    lane_index: int
    lane_role: str
    edge_id: str
    length_m: float
    width_m: float
    road_s_m: float
    offset_m: float
    gap_m: float
    relation: Relation
    relative_lane: int | None
    """None when the vehicle is not on a lane of the ego's road."""
    lane_s_m: float | None
    """Arc length of its centre on its lane's path through the road (None off the road): for prediction."""
    lateral_offset_m: float
    """Signed distance of the centre from its lane's centre line, positive to the left (as the ego's): the
    collision causes compare the two. In SUMO with ``simulation: {centre_lateral_offsets: false}``, SUMO's lateral
    position instead, which is the front's (a vehicle turned to its lane has its centre off it)."""
    next_edge_id: str
    """The street its route takes after the one it is on or leaving ('' unknown or at its route's end): which
    way it leaves the junction ahead, to predict it along."""
    accel_mps2: float
    """Its acceleration in the last step (negative: braking; 0 where the world does not tell)."""

    def to_json(self) -> dict[str, Any]:
        return _rounded(self)


@_fast_init
@dataclass(frozen=True, slots=True)
class EmergencyVehicleObservation:
    """An emergency-class vehicle (an ambulance) anywhere in the simulation, relative to the ego."""

    vehicle: VehicleObservation
    relation: Relation
    distance_m: float
    """Bumper-to-bumper distance along the road (behind: its front to the ego's rear); 0 when alongside."""
    closing_speed_mps: float
    """How fast ``distance_m`` shrinks (positive = it is catching up / we are catching up)."""
    time_to_reach_s: float | None
    """distance / closing speed when closing, else None."""
    same_lane: bool

    def to_json(self) -> dict[str, Any]:
        data = self.vehicle.to_json()
        data.update(
            relation=self.relation,
            distance_m=round(self.distance_m, 3),
            closing_speed_mps=round(self.closing_speed_mps, 3),
            time_to_reach_s=None if self.time_to_reach_s is None else round(self.time_to_reach_s, 3),
            same_lane=self.same_lane,
        )
        return data


@_fast_init
@dataclass(frozen=True, slots=True)
class ObstacleObservation:
    """A static obstacle (a stopped vehicle SUMO traffic must drive around)."""

    id: str
    type_id: str
    x_m: float
    y_m: float
    heading_rad: float
    length_m: float
    width_m: float
    lane_id: str
    lane_index: int
    lane_role: str
    road_s_m: float
    offset_m: float
    gap_m: float
    relation: Relation
    relative_lane: int | None

    def to_json(self) -> dict[str, Any]:
        return _rounded(self)


@_fast_init
@dataclass(frozen=True, slots=True)
class CollisionObservation:
    """A collision in the last step: as SUMO reported it, or an overlap of the ego's box we found ourselves.

    SUMO does not see the part of the ego that sticks into the next lane (with or without the sublane model)
    and reports a collision only once the ego's centre is across the line; ``source="geometry"`` records (the
    box overlap of :mod:`agentic_mpc.world.collisions`) catch those. They are per step: the metrics count
    contact episodes and their causes with :class:`~agentic_mpc.world.collisions.CollisionTracker`.
    """

    collider: str
    victim: str
    collider_type: str
    victim_type: str
    collider_speed_mps: float
    victim_speed_mps: float
    kind: str
    lane_id: str
    pos_m: float
    involves_ego: bool
    source: Literal["sumo", "geometry"]
    footprint_gap_m: float
    """The distance between the two footprints at this step: 0 for our overlaps; for SUMO's reports of the ego,
    measured (SUMO checks in lane coordinates, which on a curve can report cars a metre apart); NaN when not
    measured (a report without the ego, or with a vehicle not in view)."""

    @property
    def ego_contact(self) -> bool:
        """The ego touches the other: our footprints confirm it within
        :data:`~agentic_mpc.world.collisions.CONTACT_TOLERANCE_M` (unmeasured reports of the ego are trusted)."""
        return self.involves_ego and not self.footprint_gap_m > CONTACT_TOLERANCE_M

    def to_json(self) -> dict[str, Any]:
        return _rounded(self)


@dataclass(frozen=True, slots=True)
class JunctionAhead:
    """A junction on the ego's route that it has not left yet, as the world sees it this step (a few a step: the
    generated ``__init__``, with its defaults)."""

    junction_id: str
    stop_s_m: float
    """Along-road position of the stop line (where the ego's lane enters the junction)."""
    exit_s_m: float
    """Along-road position where the ego's way through the junction ends."""
    distance_m: float
    """From the ego's front bumper to the stop line (negative: the front is past it)."""
    direction: Literal["straight", "left", "right", "turn"]
    signal: Literal["green", "yellow", "red", "off"] | None
    """The light for the ego's movement (None: no traffic light)."""
    must_yield: bool
    """The ego's movement gives way (a minor road, a stop sign, a left turn on green against oncoming traffic)."""
    stop_sign: bool
    """The ego must stop at the line before it goes (a stop sign, an all-way stop)."""
    foe_arrival_s: float | None
    """How soon the first vehicle on a movement with priority over the ego's reaches the junction (0: inside it;
    None: none within sight, or the ego has priority). Where the ego waits inside (``wait_s_m``), the movements it
    waits for there are left out."""
    wait_s_m: float | None = None
    """Along-road position inside the junction where the ego's front waits for a gap in the movements its turn
    crosses further in (SUMO's internal junction, a left turn's; None: it gives way only at the line)."""
    inside_foe_arrival_s: float | None = None
    """As ``foe_arrival_s``, for the movements the ego waits for at ``wait_s_m`` (while its front is before it)."""

    def to_json(self) -> dict[str, Any]:
        return _rounded(self)


@dataclass(frozen=True, slots=True)
class Observation:
    """One step's snapshot of the world, from the ego's point of view."""

    time_s: float
    ego: EgoObservation
    traffic: tuple[VehicleObservation, ...]
    """Vehicles within sensing range (obstacles excluded; an emergency vehicle in range is here too)."""
    emergency_vehicles: tuple[EmergencyVehicleObservation, ...]
    obstacles: tuple[ObstacleObservation, ...]
    collisions: tuple[CollisionObservation, ...]
    junctions_ahead: tuple[JunctionAhead, ...] = ()
    """The next junctions on the ego's route, nearest first (worlds without junctions: none); see
    ``sumo://route`` (not in :meth:`to_json`)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict with exactly the keys of :data:`JSON_KEYS`."""
        return {
            "time_s": round(self.time_s, 3),
            "ego": self.ego.to_json(),
            "traffic": [v.to_json() for v in self.traffic],
            "emergency_vehicles": [e.to_json() for e in self.emergency_vehicles],
            "obstacles": [o.to_json() for o in self.obstacles],
            "collisions": [c.to_json() for c in self.collisions],
        }

    def vehicle(self, vehicle_id: str) -> VehicleObservation | None:
        return next((v for v in self.traffic if v.id == vehicle_id), None)

    @property
    def ego_collided(self) -> bool:
        return any(c.ego_contact for c in self.collisions)
