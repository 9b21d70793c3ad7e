"""What every primitive objective shares: the rollouts it scores, the per-step context, and the fused terms.

A primitive is an immutable, validated set of parameters (a pydantic model). Once per control step the
controller calls ``prepare(context)``, which returns a :class:`PreparedCost` holding whatever the primitive
derives from the current state (reference points, for example). A prepared cost has two faces:

- ``cost(rollouts)``: the readable NumPy definition over materialised rollouts, shape (S,). This is the
  reference the tests check and what a user-written primitive must provide.
- ``add_fused_terms(terms)``: optional. Built-in primitives describe themselves as terms of the fused
  Numba kernel (``controller/kernels.py``), which rolls out and scores all samples without materialising
  rollouts. A primitive that returns ``False`` makes the controller use the reference path for that step.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray
from pydantic import ConfigDict

from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.vehicle import VehicleParams

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Rollouts:
    """Predicted trajectories of all samples as (H, S) arrays.

    States are k = 1..H (after each input), inputs k = 0..H-1. ``delta`` is the saturated steering the
    vehicle applies; ``delta_command`` and ``ab_command`` are the raw Fourier series before saturation
    (the soft input constraints of J0 look at those).
    """

    x_m: FloatArray
    y_m: FloatArray
    phi_rad: FloatArray
    v_mps: FloatArray
    delta: FloatArray
    throttle: FloatArray
    brake: FloatArray
    delta_command: FloatArray
    ab_command: FloatArray

    @property
    def horizon(self) -> int:
        return self.x_m.shape[0]

    @property
    def samples(self) -> int:
        return self.x_m.shape[1]


@dataclass(frozen=True, slots=True)
class TrackingReference:
    """The reference of the attached path tracking primitive at this step: points and unit tangents (H, 2)."""

    points: FloatArray
    tangents: FloatArray


@dataclass(frozen=True, slots=True)
class MovingDisc:
    """A disc the ego must keep clear of, predicted over the horizon: centres (H, 2), radius in metres.

    The traffic around the ego arrives as these (see the SUMO bridge); the controller does not know where
    they come from.
    """

    centres: FloatArray
    radius_m: float
    headings: FloatArray | None = None
    """Unit vectors (H, 2): the heading the cover assumes the ego aligned with (the covered vehicle's). An ego
    turned by psi against it reaches ``a |sin psi| - b (1 - |cos psi|)`` further sideways with its corner (a, b
    its half length and half width, ``ego_half_extents_m``), and the body's radius grows by that. None: the cover
    does not depend on the ego's heading (a round ego)."""
    ego_half_extents_m: tuple[float, float] = (0.0, 0.0)
    body_radius_m: float | None = None
    """The part of the cover that is the two bodies (with the clearance margin), which grows with the ego's
    angle; the disc's radius is ``max(radius_m, body_radius_m + growth)``. None: ``radius_m`` (a cover wider than
    the bodies, such as one keeping the ego's centre out of a lane, grows only once the body's reaches past it)."""


@dataclass(frozen=True, slots=True)
class Leader:
    """A vehicle ahead in the ego's path, predicted over the horizon, for J0's time gap.

    ``contact_points`` (H, 2): where the ego's CENTRE would be, on its path, with its front bumper touching
    the leader's rear bumper at stage k = 1..H. ``tangents`` (H, 2): unit direction of the path between the
    ego and that point; the predicted gap of a state p is ``tangents[k] . (contact_points[k] - p)``. Measured
    along the path, so moving sideways in the lane does not open it: only falling back does.
    """

    contact_points: FloatArray
    tangents: FloatArray
    queue_lateral_m: float | None = None
    """Set when the leader drives up to a blockage in its lane (it will stand in the queue behind it): J0 then
    wants room behind it at standstill to pull out this far aside (the cover's radius), not only d_0."""


@dataclass(frozen=True, slots=True)
class Blockage:
    """The tail of something standing in a lane that the ego may have to pull out around: a stopped obstacle,
    or the last car of the queue standing behind one. ``x_m, y_m``: the centre of the rearmost disc the ego's
    centre must avoid (radius ``radius_m``), on the lane's centre line; ``tangent``: the lane's direction there
    (unit); ``lateral_offset_m``: how far left of that line the car itself stands (a car aligned to the side of
    its lane). For J0's queue room (:mod:`agentic_mpc.primitives.mandatory`)."""

    x_m: float
    y_m: float
    tangent_x: float
    tangent_y: float
    radius_m: float
    lateral_offset_m: float = 0.0


STANDING_PLAN_MPS = 1.0
"""A plan that ends slower than this stands (J0's lane lines, J2's rims), and a car at least this fast moves: a car
already standing is not charged for where it stands, which it can only leave by moving on."""


@dataclass(frozen=True, slots=True)
class LaneLines:
    """The lines between a road's lanes near the ego, for J0's "do not stand across a lane line": the road's
    reference line sampled every ``spacing_m`` from the ego's position on (``points``, unit ``tangents``, (n, 2)),
    and each line's offset to the left of it. The ego's half extents say how far its body reaches sideways."""

    points: FloatArray
    tangents: FloatArray
    spacing_m: float
    offsets_m: tuple[float, ...]
    ego_half_length_m: float
    ego_half_width_m: float


@dataclass(frozen=True, slots=True)
class Surroundings:
    """What the world tells the controller at one step, independent of any simulator."""

    moving_discs: tuple[MovingDisc, ...] = ()
    road_left_edge: TrackingReference | None = None
    road_right_edge: TrackingReference | None = None
    leaders: tuple[Leader, ...] = ()
    """Vehicles ahead in the ego's path (usually one; a car cutting in adds another)."""
    blockages: tuple[Blockage, ...] = ()
    """Standing things the ego keeps room to pull out behind (not also leaders)."""
    reference_shift_m: float = 0.0
    """J1 follows its path shifted this far to the left (negative: right): the lane the ego passes a blockage
    of its tracked lane in, on a road whose lanes run parallel (:class:`~agentic_mpc.primitives.PathTracking`)."""
    lane_lines: LaneLines | None = None
    """The lines between lanes: a plan that ends standing across one pays (a yield that stopped straddling two
    lanes was struck by the ambulance it made way for: docs/traffic.md)."""
    reference_speed_cap_mps: float | None = None
    """J1's reference speed is at most this: coming up to a queue in the lane J1 follows, a speed it can stop
    from with room to pull out (the horizon alone sees 2 s ahead: at 15 m/s, less than the way to stop)."""


@dataclass(frozen=True, slots=True)
class StepContext:
    """Everything a primitive may read when it prepares for one control step."""

    state: FloatArray
    """Current [x_m, y_m, phi_rad, v_mps]."""
    horizon: int
    params: VehicleParams
    surroundings: Surroundings = Surroundings()
    tracking_reference: TrackingReference | None = None
    """Set by the specification after the path tracking primitive has prepared."""
    previous_input: tuple[float, float] = (0.0, 0.0)
    """The (delta, throttle/brake) applied at the previous step; ab > 0 is throttle, < 0 brake."""

    @property
    def dt_s(self) -> float:
        return self.params.dt_s


class FusedArrays(NamedTuple):
    """The fused kernel's view of a whole specification at one step (all weights already scaled)."""

    track_ref: FloatArray  # (n_track, H, 2)
    track_tan: FloatArray  # (n_track, H, 2) unit tangents at the reference points
    track_weight: FloatArray  # (n_track, 2) per stage: w * ||p - r||^2 + w * (lambda - 1) * (cross-track)^2
    circles: FloatArray  # (n_circles, 4): cx, cy, r^2, weight per stage inside
    steer_sign: FloatArray  # (n, 2): sign, weight per stage on min(0, sign*delta)^2
    lateral_sign: FloatArray  # (n, 3): sign, weight per stage on min(0, sign*e_lat + dead zone)^2, dead zone
    lateral_ref: FloatArray  # (n, H, 2)
    lateral_tan: FloatArray  # (n, H, 2)
    limits: FloatArray  # (10,): steer weight, throttle/brake weight, v_max, speed weight, rate weight, previous delta,
    # previous ab, steering smoothness weight, throttle/brake smoothness weight, brake effort weight
    disc_centres: FloatArray  # (n_discs, H, 2)
    disc_headings: FloatArray  # (n_discs, H, 2) unit headings the cover assumes the ego aligned with
    disc_params: FloatArray  # (n_discs, 8): cover radius, weight per stage, body radius, ego half length, half
    # width (both 0: the radius does not depend on the ego's heading; see MovingDisc), contact weight per stage,
    # contact share squared, 1 / contact closing speed
    edge_ref: FloatArray  # (n_edges, H, 2) points on the road edges
    edge_tan: FloatArray  # (n_edges, H, 2)
    edge_params: FloatArray  # (n_edges, 3): side sign (+1 left edge, -1 right edge), margin, weight
    leader_points: FloatArray  # (n_leaders, H, 2) contact points (see Leader)
    leader_tan: FloatArray  # (n_leaders, H, 2)
    leader_start: FloatArray  # (n_leaders,): the gap now (at least the standstill gap), m
    leader_standstill: FloatArray  # (n_leaders,): the wanted gap at standstill d_0, m (more before a blockage)
    time_gap: FloatArray  # (5,): time gap s, standstill gap m (the kernel reads leader_standstill), weight per
    # stage, Huber knee m, recovery m per step
    queue_rooms: FloatArray  # (n, 11): rear disc x, y, lane tangent x, y, radius, turn radius, cos and sin of its
    # slip angle, 1/(2 decel), weight on the last stage, the car's lateral offset from the disc's line
    lane_line_table: FloatArray  # (n, 4): the road's reference line from the ego on, x, y, tangent x, y
    lane_line_offsets: FloatArray  # (m,): the lines between lanes, left of the reference line, m
    lane_line_params: FloatArray  # (5,): spacing m, weight on the last stage, standing speed m/s, ego half length,
    # half width
    rims: FloatArray  # (n, 6): circle x, y, outer radius (J2's + its rim), rim depth m, weight on the last stage,
    # standing speed m/s


@dataclass(slots=True)
class FusedTerms:
    """Collects the fused-kernel terms of one step; :meth:`build` packs them into arrays."""

    horizon: int
    track: list[tuple[FloatArray, FloatArray, float, float]] = field(default_factory=list)
    circles: list[tuple[float, float, float, float]] = field(default_factory=list)
    rims: list[tuple[float, float, float, float, float, float]] = field(default_factory=list)
    steer_sign: list[tuple[float, float]] = field(default_factory=list)
    lateral: list[tuple[float, float, float, FloatArray, FloatArray]] = field(default_factory=list)
    limits: tuple[float, ...] = (0.0, 0.0, np.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    discs: list[tuple[FloatArray, FloatArray, float, ...]] = field(default_factory=list)
    """Per disc: centres, headings, cover radius, weight, body radius, ego half length, half width
    (:class:`MovingDisc`), contact weight, share squared, 1 / closing."""
    edges: list[tuple[FloatArray, FloatArray, float, float, float]] = field(default_factory=list)
    leaders: list[tuple[FloatArray, FloatArray, float, float]] = field(default_factory=list)
    time_gap: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 1.0, 0.0)
    queue_rooms: list[tuple[float, ...]] = field(default_factory=list)
    lane_lines: tuple[FloatArray, tuple[float, ...], tuple[float, ...]] | None = None
    """The (n, 4) table, the offsets and the params of :class:`FusedArrays`' lane-line term."""

    def build(self) -> FusedArrays:
        # Called every control step: the empty and single-item cases (most of them) allocate nothing new, and
        # np.array copies a list of arrays in C where np.stack costs about 15 us in Python.
        h = self.horizon
        no_stages = _empty((0, h, 2))

        def stack(arrays: list[FloatArray]) -> FloatArray:
            if not arrays:
                return no_stages
            if len(arrays) == 1:
                return np.ascontiguousarray(arrays[0])[None]
            return np.array(arrays, dtype=np.float64)

        def table(rows: list[tuple[float, ...]], width: int) -> FloatArray:
            return _table(tuple(rows), width)

        lines, offsets, line_params = self.lane_lines or (_empty((0, 4)), (), (1.0, 0.0, 0.0, 0.0, 0.0))

        return FusedArrays(
            track_ref=stack([ref for ref, _, _, _ in self.track]),
            track_tan=stack([tan for _, tan, _, _ in self.track]),
            track_weight=table([(w, w * (lateral - 1.0)) for _, _, w, lateral in self.track], 2),
            circles=table(self.circles, 4),
            steer_sign=table(self.steer_sign, 2),
            lateral_sign=table([(sign, w, dead_zone) for sign, w, dead_zone, _, _ in self.lateral], 3),
            lateral_ref=stack([ref for *_, ref, _ in self.lateral]),
            lateral_tan=stack([tan for *_, tan in self.lateral]),
            limits=np.array(self.limits, dtype=np.float64),  # holds the previous input: new every step
            disc_centres=stack([c for c, *_ in self.discs]),
            disc_headings=stack([headings for _, headings, *_ in self.discs]),
            disc_params=table([d[2:] for d in self.discs], 8),
            edge_ref=stack([p for p, _, _, _, _ in self.edges]),
            edge_tan=stack([t for _, t, _, _, _ in self.edges]),
            edge_params=table([(side, margin, w) for _, _, side, margin, w in self.edges], 3),
            leader_points=stack([p for p, _, _, _ in self.leaders]),
            leader_tan=stack([t for _, t, _, _ in self.leaders]),
            leader_start=np.array([start for _, _, start, _ in self.leaders], dtype=np.float64),
            leader_standstill=np.array([standstill for *_, standstill in self.leaders], dtype=np.float64),
            time_gap=_table((self.time_gap,), len(self.time_gap))[0],
            queue_rooms=table(self.queue_rooms, 11),
            lane_line_table=lines,
            lane_line_offsets=_table((offsets,), len(offsets))[0],
            lane_line_params=_table((line_params,), 5)[0],
            rims=table(self.rims, 6),
        )


_EMPTY_ARRAYS: dict[tuple[int, ...], FloatArray] = {}
_TABLES: dict[tuple[tuple[tuple[float, ...], ...], int], FloatArray] = {}
_TABLES_KEPT = 512


def _empty(shape: tuple[int, ...]) -> FloatArray:
    """A shared empty array of ``shape``: it has no element to change. (Not flagged read-only: Numba would
    compile the kernel once more for every mix of read-only and writable arguments.)"""
    array = _EMPTY_ARRAYS.get(shape)
    if array is None:
        array = _EMPTY_ARRAYS[shape] = np.zeros(shape)
    return array


def _table(rows: tuple[tuple[float, ...], ...], width: int) -> FloatArray:
    """``rows`` as an (n, width) array, shared between steps with the same rows: weights and limits change
    only when the agent changes the specification, and building the array anew costs microseconds each step.
    The kernel only reads these arrays."""
    key = (rows, width)
    array = _TABLES.get(key)
    if array is None:
        if len(_TABLES) >= _TABLES_KEPT:  # bounded: rows that keep changing (e.g. leader gaps) are not kept long
            _TABLES.clear()
        array = _TABLES[key] = np.array(rows, dtype=np.float64).reshape(len(rows), width)
    return array


class PreparedCost(Protocol):
    """A primitive bound to one control step."""

    def cost(self, rollouts: Rollouts) -> FloatArray:
        """Cost of every sample, shape (S,), in plain NumPy."""
        ...

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        """Describe this cost to the fused kernel; False if it cannot be expressed there."""
        ...


class Primitive(FrozenConfig):
    """Base of all primitive objectives: frozen, validated, no unknown fields, no NaN or infinity."""

    model_config = ConfigDict(arbitrary_types_allowed=True)  # + FrozenConfig's: lane paths are not pydantic

    kind: ClassVar[str]
    """Stable identifier of the primitive family, e.g. ``path_tracking``."""
    paper_symbol: ClassVar[str] = ""
    mandatory: ClassVar[bool] = False

    @property
    def name(self) -> str:
        """The slot the primitive occupies in a specification; attaching another with the same name replaces it."""
        return self.kind

    def prepare(self, context: StepContext) -> PreparedCost:
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (for the agent's system prompt, MCP resources and CSV logs)."""
        return {"kind": self.kind, "symbol": self.paper_symbol, **self.model_dump(mode="json")}

    def summary(self) -> str:
        """One short line for logs and CSV columns."""
        fields = ", ".join(f"{k}={v}" for k, v in self.model_dump(mode="json").items() if k != "path")
        return f"{self.kind}({fields})"


def per_stage(weight: float, horizon: int, normalise_by_horizon: bool) -> float:
    """The weight of one stage: the paper sums over the horizon; normalising makes it a horizon mean."""
    return weight / horizon if normalise_by_horizon else weight
