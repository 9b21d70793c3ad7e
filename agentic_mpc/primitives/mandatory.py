"""J0, the mandatory objective: the soft constraints that no tool can detach.

- input limits: the raw steering and throttle/brake series beyond [-1, 1] (the actuators saturate there,
  so without this the sampling mean could drift deep into saturation where every sample looks the same);
- a speed limit;
- other road users: discs predicted over the horizon (``Surroundings.moving_discs``), 1-2 x
  ``vehicle_clearance_weight`` per stage inside one, and up to ``vehicle_contact_weight`` more where the bodies touch:
  the margin is soft, touching is not (docs/traffic.md: squeezed in a crawling queue, every plan inside three discs,
  the ego crept into the car ahead, which cost at most twice its margin);
- road edges (``Surroundings.road_left_edge`` / ``road_right_edge``);
- a time gap to the vehicles ahead in the ego's path (``Surroundings.leaders``): the predicted bumper-to-bumper
  gap, measured along the path, should be at least v(k) * ``time_gap_s`` + ``standstill_gap_m`` at every
  stage, but never more than the current gap + ``time_gap_recovery_mps`` x t (after a cut-in the ego falls back
  gradually); the shortfall is penalised squared up to ``time_gap_quadratic_m``, linearly beyond (Huber). Along the
  path, so leaving the lane does not reduce it: the way to satisfy it after a cut-in is to brake
  (docs/cost-design.md, "Time gap");
- queue room behind a blockage (``Surroundings.blockages``: a stopped obstacle, or the tail of the queue
  standing behind one), a terminal cost: a plan that ends in line with it (behind its rearmost disc, less
  than that disc's radius aside) pays for ending closer than the distance the model needs to pull out the
  rest of the way round it, worked out from its geometry (``VehicleParams.pull_out_distance_m`` at
  ``queue_room_steer`` of full lock: about 10 m from straight behind, less from partly aside, so that pulling
  out costs nothing on the way; for a car standing inside that room, at ``queue_room_standing_steer``: only plans
  near full lock get out from there), plus the distance to stop from its final speed at ``queue_room_decel_mps2``. So
  the ego either pulls out or comes in at a speed it can stop from with room; a plan that ends beside the blockage
  or past its rear disc pays nothing (docs/traffic.md: without it the ego stood 0.5 m behind a stopped car,
  from where no path of the model gets round, for 90 s; charged at every stage, the room made braking in lane
  cheaper than pulling out; inside the disc is not past it: "Leaving a standstill");
- standing across a lane line (``Surroundings.lane_lines``), a terminal cost while the car moves: a plan that ends
  slower than ``lane_line_standing_mps`` with the body over a line between lanes pays for how far the body reaches
  over it, squared, the more the slower it ends. Stand in a lane, or keep going until in one (docs/traffic.md: a
  yield that stopped half in the edge lane was struck by the ambulance it made way for);
- smoothness of the planned inputs: a plan whose throttle/brake jumps from stage to stage costs more, so the
  weighted average of smooth plans is smooth (docs/cost-design.md).

Every term is a stage mean over the horizon (divided by H), so weights do not depend on the horizon.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from pydantic import Field

from agentic_mpc import removed_options
from agentic_mpc.primitives.base import (
    STANDING_PLAN_MPS,
    Blockage,
    FloatArray,
    FusedTerms,
    LaneLines,
    Leader,
    Primitive,
    Rollouts,
    StepContext,
    TrackingReference,
)
from agentic_mpc.primitives.vehicle_discs import disc_cost, disc_row

TIME_GAP_WEIGHT = 10.0
"""Default ``time_gap_weight``, per m^2 per stage (tuned on the dense traffic scenario, seeds 100-119:
docs/cost-design.md "Time gap")."""
TIME_GAP_RECOVERY_MPS = 3.0
"""Default ``time_gap_recovery_mps`` (docs/cost-design.md "Time gap": a faster car merging 1 m ahead braked the
ego to half its speed without it)."""
QUEUE_ROOM_KNEE_M = 2.0
"""The queue room's shortfall costs its square up to this many metres and grows linearly beyond (Huber)."""
TIME_GAP_QUADRATIC_M = 2.0
"""Default ``time_gap_quadratic_m``: squared beyond 2 m of shortfall, a cut-in made the cost spread so wide that
the averaged steering wandered out of the lane (same section)."""


class Mandatory(Primitive):
    """J0: input and speed soft constraints, clearance from other road users, staying on the road."""

    kind: ClassVar[str] = "mandatory"
    paper_symbol: ClassVar[str] = "J0"
    mandatory: ClassVar[bool] = True
    removed_fields: ClassVar[dict[str, str]] = removed_options.MANDATORY

    steer_limit_weight: float = Field(100.0, ge=0, description="per stage, on (|delta_cmd| - 1)^2 beyond the limit")
    throttle_brake_limit_weight: float = Field(10.0, ge=0, description="per stage, on (|ab_cmd| - 1)^2 beyond")
    speed_limit_mps: float = Field(40.0, gt=0, description="soft upper speed limit")
    speed_limit_weight: float = Field(10.0, ge=0, description="per stage, on (v - limit)^2 beyond the limit")
    vehicle_clearance_weight: float = Field(
        200.0, ge=0, description="per stage inside another road user's disc, scaled by 1 + penetration depth"
    )
    vehicle_contact_weight: float = Field(
        4000.0, ge=0, description="per stage where the bodies touch (inside vehicle_contact_share of a disc's bodies' "
        "radius), x (1 - d²/r_touch²) x how far the ego closes in (vehicle_contact_closing_mps), on top of the "
        "clearance: the margin is soft, touching is not"
    )
    vehicle_contact_share: float = Field(
        0.8, gt=0, le=1.0, description="the share of a disc's bodies' radius (the half widths + the 0.5 m clearance "
        "margin: 0.8 x 2.4 m = 1.9 m for two cars) inside which they touch"
    )
    vehicle_contact_closing_mps: float = Field(
        1.0, gt=0, description="the contact is charged as far as the ego closes in by its own motion, in full from "
        "this speed (relative to the other's, across its heading, and along it onto one ahead): a standing ego is "
        "not pushed to flee a contact that another drives into"
    )
    input_rate_weight: float = Field(
        0.0, ge=0, description="on the change of the first input from the previous step's (anti-chatter)"
    )
    steer_smoothness_weight: float = Field(
        10.0, ge=0, description="per stage, on the planned steering's step (delta_cmd(k) - delta_cmd(k-1))^2"
    )
    throttle_brake_smoothness_weight: float = Field(
        1000.0, ge=0, description="per stage, on the planned throttle/brake's step (ab_cmd(k) - ab_cmd(k-1))^2"
    )
    brake_effort_weight: float = Field(
        1.0, ge=0, description="per stage, on brake^2: no harder braking than needed, and a stopped car lets go"
    )
    road_edge_weight: float = Field(50.0, ge=0, description="per stage, on (margin - distance inside edge)^2")
    road_edge_margin_m: float = Field(1.0, ge=0, description="how far the ego's centre keeps from a road edge")
    time_gap_s: float = Field(
        1.2, ge=0, le=10.0, description="wanted time gap T_h to a vehicle ahead in the ego's path, in seconds"
    )
    standstill_gap_m: float = Field(
        2.0, ge=0, le=50.0, description="wanted bumper-to-bumper gap d_0 at standstill, in metres (added to v*T_h)"
    )
    time_gap_weight: float = Field(
        TIME_GAP_WEIGHT,
        ge=0,
        description="per stage, on the gap shortfall max(0, v*T_h + d_0 - gap) in m, squared up to "
        "time_gap_quadratic_m and linear beyond; the gap is measured along the ego's path to each leader's rear "
        "bumper (0 switches the term off)",
    )
    time_gap_recovery_mps: float = Field(
        TIME_GAP_RECOVERY_MPS,
        gt=0,
        description="the wanted gap is at most the current gap (at least d_0) + this rate x time: after a cut-in "
        "the ego falls back at this many m/s relative to the car instead of braking at once to the full gap",
    )
    time_gap_quadratic_m: float = Field(
        TIME_GAP_QUADRATIC_M,
        gt=0,
        description="shortfalls up to this many metres cost shortfall^2, longer ones grow linearly (Huber): a car "
        "cutting in far inside the wanted gap makes the ego brake firmly, not slam the brakes",
    )

    queue_room_weight: float = Field(
        20.0, ge=0, description="on the queue room's shortfall in m at the plan's end (squared up to 2 m, then "
        "linear; a horizon's worth, as a stage weight x H); 0: off"
    )
    queue_room_steer: float = Field(
        0.5, gt=0, le=1.0, description="share of full steering lock the room to pull out is worked out for"
    )
    queue_room_standing_steer: float | None = Field(
        1.0, gt=0, le=1.0, description="a car standing inside the room gets the room worked out for this share of full "
        "lock: from there only plans near full lock get out, and each on the way paid more than standing (None: "
        "queue_room_steer throughout; docs/traffic.md, 'Gap acceptance beyond the horizon, and standing inside the "
        "room to pull out')"
    )
    queue_room_decel_mps2: float = Field(
        4.0, gt=0, description="the wanted room grows by the distance to stop at this deceleration, v^2 / (2 b)"
    )

    lane_line_standing_weight: float = Field(
        50.0, ge=0, description="on (how far the body reaches over a line between lanes, m)^2 x (1 - v / "
        "lane_line_standing_mps) at the plan's end (a horizon's worth); 0: off"
    )
    lane_line_standing_mps: float = Field(
        STANDING_PLAN_MPS, gt=0, description="a plan that ends slower than this stands: across a lane line, it pays"
    )

    def prepare(self, context: StepContext) -> PreparedMandatory:
        s = context.surroundings
        edges: list[tuple[TrackingReference, float]] = []
        if s.road_left_edge is not None:
            edges.append((s.road_left_edge, 1.0))
        if s.road_right_edge is not None:
            edges.append((s.road_right_edge, -1.0))
        leaders = s.leaders if self.time_gap_weight > 0.0 else ()
        # The gap now (from the first stage's contact point), where the wanted gap may start from.
        x_m, y_m = context.state[0], context.state[1]
        standstill = tuple(
            self.standstill_gap_m if leader.queue_lateral_m is None else
            max(self.standstill_gap_m, context.params.pull_out_distance_m(leader.queue_lateral_m, self.queue_room_steer))
            for leader in leaders
        )
        starts = tuple(max(d0, _gap_along_path_m(leader, x_m, y_m)) for leader, d0 in zip(leaders, standstill))
        turn = context.params.pull_out_turn(self.queue_room_steer)
        # Standing inside that room, a plan gets out only near full lock and every plan on the way paid more than
        # standing (3804, 3808 stood 20-110 s behind the curve's car): there, the room for queue_room_standing_steer.
        standing = self.queue_room_standing_steer is not None and context.state[3] < STANDING_PLAN_MPS
        standing_turn = context.params.pull_out_turn(self.queue_room_standing_steer) if standing else None
        rooms = tuple(
            (b.x_m, b.y_m, b.tangent_x, b.tangent_y, b.radius_m,
             *(standing_turn if standing_turn and _inside_room(b, x_m, y_m, *turn) else turn),
             0.5 / self.queue_room_decel_mps2, self.queue_room_weight, b.lateral_offset_m)
            for b in (s.blockages if self.queue_room_weight > 0.0 else ())
        )
        # Only for a car that moves: one already standing across a line is not charged for what it cannot leave
        # but by moving on (in a stand before three stopped cars abreast, it crept at centimetres to get off it).
        moving = float(context.state[3]) >= self.lane_line_standing_mps
        lines = s.lane_lines if moving and self.lane_line_standing_weight > 0.0 else None
        if lines is not None and (not lines.offsets_m or len(lines.points) == 0):
            lines = None
        return PreparedMandatory(self, context.horizon, s.moving_discs, tuple(edges), context.previous_input, leaders,
                                 starts, context.dt_s, rooms, standstill, lines)


def _inside_room(b: Blockage, x_m: float, y_m: float, turn_radius: float, cos_g: float, sin_g: float) -> bool:
    """Whether a car standing at (x_m, y_m) is closer to ``b`` than the room to pull out with that turn."""
    behind = b.tangent_x * (b.x_m - x_m) + b.tangent_y * (b.y_m - y_m)
    beside = b.tangent_x * (b.y_m - y_m) - b.tangent_y * (b.x_m - x_m)
    if behind <= -b.radius_m or abs(beside) >= b.radius_m:
        return False
    cos_end = cos_g - (b.radius_m - min(abs(beside + b.lateral_offset_m), b.radius_m)) / turn_radius
    return turn_radius * (math.sqrt(1.0 - cos_end * cos_end) - sin_g) > behind - b.radius_m


def _gap_along_path_m(leader: Leader, x_m: float, y_m: float) -> float:
    """``tangents[0] . (contact_points[0] - p)`` spelled out as the fused kernel spells it: ``@`` on two
    2-vectors is a BLAS call whose kernel, and so the last bit, depends on the CPU (docs/reproducibility.md)."""
    tx, ty = float(leader.tangents[0, 0]), float(leader.tangents[0, 1])
    lx, ly = float(leader.contact_points[0, 0]), float(leader.contact_points[0, 1])
    return tx * (lx - float(x_m)) + ty * (ly - float(y_m))


@dataclass(frozen=True, slots=True)
class PreparedMandatory:
    spec: Mandatory
    horizon: int
    discs: tuple
    edges: tuple[tuple[TrackingReference, float], ...]
    previous_input: tuple[float, float]
    leaders: tuple[Leader, ...] = ()
    gap_starts_m: tuple[float, ...] = ()
    dt_s: float = 0.0
    queue_rooms: tuple[tuple[float, ...], ...] = ()
    """Per blockage: rear disc x, y, lane tangent x, y, radius, the pull-out turn (radius, cos and sin of the
    slip angle), 1 / (2 b), weight (on the last stage: the whole horizon's worth), the car's offset left of the
    disc's line."""
    standstill_gaps_m: tuple[float, ...] = ()
    """Per leader: d_0, or the room to pull out behind one that drives up to a blockage."""
    lane_lines: LaneLines | None = None

    def _lane_line_params(self) -> tuple[float, ...]:
        lines, p = self.lane_lines, self.spec
        assert lines is not None
        return (lines.spacing_m, p.lane_line_standing_weight, p.lane_line_standing_mps, lines.ego_half_length_m,
                lines.ego_half_width_m)

    def _contact(self) -> tuple[float, float, float]:
        p = self.spec
        return p.vehicle_contact_weight, p.vehicle_contact_share, p.vehicle_contact_closing_mps

    def cost(self, r: Rollouts) -> FloatArray:
        p, h = self.spec, self.horizon
        total = p.steer_limit_weight / h * np.sum(np.maximum(0.0, np.abs(r.delta_command) - 1.0) ** 2, axis=0)
        total += p.throttle_brake_limit_weight / h * np.sum(np.maximum(0.0, np.abs(r.ab_command) - 1.0) ** 2, axis=0)
        total += p.speed_limit_weight / h * np.sum(np.maximum(0.0, r.v_mps - p.speed_limit_mps) ** 2, axis=0)
        previous_delta, previous_ab = self.previous_input
        first_ab = np.clip(r.ab_command[0], -1.0, 1.0)
        total += p.input_rate_weight * ((r.delta[0] - previous_delta) ** 2 + (first_ab - previous_ab) ** 2)
        total += p.steer_smoothness_weight / h * np.sum(np.diff(r.delta_command, axis=0) ** 2, axis=0)
        total += p.throttle_brake_smoothness_weight / h * np.sum(np.diff(r.ab_command, axis=0) ** 2, axis=0)
        total += p.brake_effort_weight / h * np.sum(r.brake**2, axis=0)
        for disc in self.discs:
            total += disc_cost(disc, r, self.dt_s, p.vehicle_clearance_weight, *self._contact())
        for edge, side in self.edges:
            ex, ey = edge.points[:, 0:1], edge.points[:, 1:2]
            tx, ty = edge.tangents[:, 0:1], edge.tangents[:, 1:2]
            e_lat = tx * (r.y_m - ey) - ty * (r.x_m - ex)
            violation = np.maximum(0.0, p.road_edge_margin_m + side * e_lat)
            total += p.road_edge_weight / h * np.sum(violation**2, axis=0)
        recovery = p.time_gap_recovery_mps * self.dt_s * np.arange(1, h + 1)[:, None]
        for leader, start, d0 in zip(self.leaders, self.gap_starts_m, self.standstill_gaps_m, strict=True):
            cx, cy = leader.contact_points[:, 0:1], leader.contact_points[:, 1:2]
            tx, ty = leader.tangents[:, 0:1], leader.tangents[:, 1:2]
            gap = tx * (cx - r.x_m) + ty * (cy - r.y_m)
            wanted = np.minimum(p.time_gap_s * r.v_mps + d0, start + recovery)
            shortfall = np.maximum(0.0, wanted - gap)
            q = p.time_gap_quadratic_m
            huber = np.where(shortfall > q, q * (2.0 * shortfall - q), shortfall**2)
            total += p.time_gap_weight / h * np.sum(huber, axis=0)
        for cx, cy, tx, ty, radius, turn_radius, cos_g, sin_g, half_inv_decel, weight, offset in self.queue_rooms:
            x_end, y_end, v_end = r.x_m[-1], r.y_m[-1], r.v_mps[-1]  # on the last state only
            behind = tx * (cx - x_end) + ty * (cy - y_end)  # along the lane, to the rear disc's centre
            beside = tx * (cy - y_end) - ty * (cx - x_end)  # the disc's line right of the plan's end
            # In line is the lane's band; how far aside the plan still has to get is from the car itself, which
            # may stand to one side (behind a car at 1.6 m right of its lane, an ego at 1.3 m right was counted
            # 1.3 m aside, crept up to 1.6 m and blocked the car's own way out: docs/traffic.md).
            aside = np.abs(beside + offset)
            # The run needed to get the rest of the way aside (VehicleParams.pull_out_distance_m), + stopping.
            cos_end = cos_g - (radius - np.minimum(aside, radius)) / turn_radius  # out of line: masked
            wanted = turn_radius * (np.sqrt(1.0 - cos_end * cos_end) - sin_g) + half_inv_decel * v_end * v_end
            shortfall = np.where((behind > -radius) & (np.abs(beside) < radius),
                                 np.maximum(0.0, wanted - (behind - radius)), 0.0)
            q = QUEUE_ROOM_KNEE_M
            total += weight * np.where(shortfall > q, q * (2.0 * shortfall - q), shortfall**2)
        if self.lane_lines is not None:
            total += self._standing_across_lines(r)
        return total

    def _standing_across_lines(self, r: Rollouts) -> FloatArray:
        """The lane-line term on the last state, written as the fused kernel writes it."""
        lines = self.lane_lines
        assert lines is not None
        spacing, weight, standing, half_length, half_width = self._lane_line_params()
        x, y, v, phi = r.x_m[-1], r.y_m[-1], r.v_mps[-1], r.phi_rad[-1]
        (x0, y0), (t0x, t0y) = lines.points[0], lines.tangents[0]
        along = t0x * (x - x0) + t0y * (y - y0)  # along the road from the ego, by its tangent here: the row
        j = np.clip(np.floor(along / spacing + 0.5), 0, len(lines.points) - 1).astype(np.int64)
        px, py = lines.points[j, 0], lines.points[j, 1]
        tx, ty = lines.tangents[j, 0], lines.tangents[j, 1]
        lateral = tx * (y - py) - ty * (x - px)
        c, s = np.cos(phi), np.sin(phi)
        reach = half_width * np.abs(c * tx + s * ty) + half_length * np.abs(s * tx - c * ty)
        slow = np.where(v < standing, 1.0 - v / standing, 0.0)
        total = np.zeros_like(x)
        for offset in lines.offsets_m:
            overlap = np.maximum(0.0, reach - np.abs(lateral - offset))
            total += weight * slow * overlap * overlap
        return total

    def add_fused_terms(self, terms: FusedTerms) -> bool:
        p, h = self.spec, self.horizon
        terms.limits = (
            p.steer_limit_weight / h,
            p.throttle_brake_limit_weight / h,
            p.speed_limit_mps,
            p.speed_limit_weight / h,
            p.input_rate_weight,
            *self.previous_input,
            p.steer_smoothness_weight / h,
            p.throttle_brake_smoothness_weight / h,
            p.brake_effort_weight / h,
        )
        terms.discs.extend(disc_row(disc, h, p.vehicle_clearance_weight, *self._contact()) for disc in self.discs)
        for edge, side in self.edges:
            terms.edges.append((edge.points, edge.tangents, side, p.road_edge_margin_m, p.road_edge_weight / h))
        terms.time_gap = (p.time_gap_s, p.standstill_gap_m, p.time_gap_weight / h, p.time_gap_quadratic_m,
                          p.time_gap_recovery_mps * self.dt_s)
        for leader, start, d0 in zip(self.leaders, self.gap_starts_m, self.standstill_gaps_m, strict=True):
            terms.leaders.append((leader.contact_points, leader.tangents, start, d0))
        terms.queue_rooms.extend(self.queue_rooms)
        if self.lane_lines is not None:
            table = np.ascontiguousarray(np.hstack((self.lane_lines.points, self.lane_lines.tangents)))
            terms.lane_lines = (table, self.lane_lines.offsets_m, self._lane_line_params())
        return True
