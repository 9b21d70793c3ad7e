"""Observation -> the controller's :class:`Surroundings` (other road users as discs, road edges as lines).

Prediction: each nearby vehicle keeps its speed along its own lane over the horizon (the brief's model;
SUMO's vehicles do change lanes and brake, which the next step's observation then shows). On a route, a vehicle
on a lane that is not the route's (a crossing street, oncoming, a junction's inside) drives along its lane and on
the way its route goes, braking as it brakes now, its body turned as SUMO turns it
(:meth:`~agentic_mpc.sumo.lane_tables.LaneTables.place`, :func:`~agentic_mpc.polylines.kernels.body_disc_centres`).

Shape: the controller treats the ego as a point (its centre), so each vehicle is inflated by the ego: the ego's
centre must avoid a (L + L_ego) x 2 half_w rectangle round the vehicle's centre, covered by a row of discs along its
heading (:func:`disc_cover`; one disc as long would block the next lanes). Physically half_w = (W + W_ego)/2; on a
lane the ego may enter, at least half the lane width + ``lane_entry_margin_m``: without the sublane model SUMO moves
the ego onto a lane once its FRONT bumper crosses the line, and reports a collision with anyone there who overlaps
it lengthwise (Scenario 2: the front 1.5 cm across, beside a car's rear bumper); the margin covers the front leading
the centre by L_ego/2 sin(heading). Lanes the ego may not enter keep the physical cover (a wider one squeezes it).

Following distance: the cover of a vehicle ahead in the ego's lane reaches back by ``leader_standstill_gap_m``,
never over the ego. J0's time gap (below) keeps the distance along the path with a gradient (a cover reaching back
in proportion to the speed paid the ego for moving sideways after a cut-in: docs/cost-design.md "Time gap").

Tactics (:mod:`agentic_mpc.tactics`): the run loop hands each step's :class:`TacticalPlan`: the lane J1 follows
instead of the tracked one (J1's reference is shifted there, and the corridor and the time-gap leaders are that
lane's), the blockages (J0's queue room behind each, rule ``queue_room``), the passing lanes (corridor and
lane-entry covers) and gap acceptance (followers there predicted to yield).

Time gap (J0's ``Surroundings.leaders``, :meth:`SurroundingsBuilder.leaders`): the nearest vehicle ahead on the lane
J1 tracks (else the ego's own), plus a nearer one from a lane beside whose box overlaps the path lane now or within
``CUT_IN_LOOKAHEAD_S`` at its lateral speed (SUMO reports lateral motion only with the sublane model). Each is
predicted at constant speed along the path, and J0 measures the gap along it: moving sideways does not open it.

Which vehicles: those that can come within reach along the road during the horizon (a 1-D test at constant speeds,
with slack for the ego's own speed changes), capped by ``range_ahead_m`` / ``range_behind_m``. One directly behind
in the ego's lane is left out by default: keeping its distance is its job (SUMO's car following does it), and
predicted at constant speed into the ego it would make the ego flee forwards.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from agentic_mpc.polylines.kernels import body_disc_centres, disc_centres, locate, points_at, side_lines
from agentic_mpc.polylines.polyline import Polyline
from agentic_mpc.primitives import LaneLines, Leader, MovingDisc, Surroundings, TrackingReference
from agentic_mpc.sumo.config import SurroundingsConfig
from agentic_mpc.sumo.lane_tables import LaneTables
from agentic_mpc.sumo.network import Road
from agentic_mpc.tactics.covers import DiscCover, disc_cover
from agentic_mpc.tactics.layer import NO_TACTICS, TacticalPlan, TacticalRoad
from agentic_mpc.tactics.queues import QUEUE_LEADER_WITHIN_M, Queue, drives_up_to_a_queue
from agentic_mpc.world.observation import Observation, VehicleObservation

CUT_IN_LOOKAHEAD_S = 1.0
"""A neighbour whose box is predicted to reach into the ego's path lane within this time counts as a leader."""
LANE_LINE_SPACING_M = 1.0
"""J0's lane lines are sampled this often along the road: the nearest row to a plan's end is at most 0.5 m off."""
LANE_LINE_SPARE_POINTS = 6
"""Rows beyond the way the ego covers at its speed in a horizon (a plan that speeds up ends a little further)."""
MAX_LEADERS = 3


class SurroundingsBuilder:
    """Builds :class:`Surroundings` for the controller's horizon from an observation."""

    def __init__(
        self,
        road: Road,
        ego_length_m: float,
        ego_width_m: float,
        horizon: int,
        dt_s: float,
        config: SurroundingsConfig = SurroundingsConfig(),
    ) -> None:
        self.road = road
        self.ego_length_m = ego_length_m
        self.ego_width_m = ego_width_m
        # J0's covers assume the ego aligned with each vehicle; turned, its corners reach further (MovingDisc)
        self._ego_half_extents_m = (0.5 * ego_length_m, 0.5 * ego_width_m) if config.heading_aware_covers else (0.0, 0.0)
        self.horizon = horizon
        self.dt_s = dt_s
        self.config = config
        self._steps = dt_s * np.arange(1, horizon + 1)  # k = 1..H: the rollouts' states
        self._horizon_s = horizon * dt_s
        bounds = self._lane_bounds = road.lane_bounds_m
        self._lane_centres = tuple(0.5 * (left + right) for left, right in bounds)
        # a lane's right line that is not the road's: the lines between lanes
        self._lines_between_lanes = tuple(sorted(right for _, right in bounds if right > min(r for _, r in bounds)))
        self._covers: dict[tuple[float, float, float], DiscCover] = {}
        self._enterable_lanes: frozenset[int] = frozenset(range(road.lane_count))
        self._plan: TacticalPlan = NO_TACTICS
        # a route's other lanes (oncoming, crossing, internal): their vehicles are predicted along them
        self._other_lanes = LaneTables(road.network.net) if road.is_route else None

    @property
    def tactical_road(self) -> TacticalRoad:
        """The road and sizes the tactics layer sees (its queues are then the ones these covers make)."""
        c = self.config
        return TacticalRoad(self._lane_centres, self.ego_length_m, self.ego_width_m, c.clearance_margin_m,
                            c.max_discs_per_vehicle, c.range_ahead_m, self.road.speed_zones,
                            self.road.speed_limit_mps, partial(locate, self.road.reference_table))

    def _cover(self, vehicle: VehicleObservation, physical: bool = False) -> DiscCover:
        """The disc cover around ``vehicle``: the lane-entry one on an enterable lane, unless ``physical``."""
        c = self.config
        min_half_width = 0.0
        if (not physical and c.lane_entry_margin_m is not None and vehicle.lane_s_m is not None
                and vehicle.lane_index in self._enterable_lanes):
            # To its lane's edge + margin from the lane's centre: a car aligned towards the ego (rescue lane) must
            # not push the cover into the ego's lane (beside such a queue the ego could not drive on).
            side = 1.0 if (vehicle.relative_lane or 0) > 0 else -1.0  # +1: its lane is left of the ego's
            towards_ego = max(0.0, -side * vehicle.lateral_offset_m)
            min_half_width = 0.5 * self.road.lane_widths_m[vehicle.lane_index] + c.lane_entry_margin_m - towards_ego
        key = (vehicle.length_m, vehicle.width_m, min_half_width)
        cover = self._covers.get(key)
        if cover is None:
            cover = disc_cover(vehicle.length_m, vehicle.width_m, self.ego_length_m, self.ego_width_m,
                               c.clearance_margin_m, c.max_discs_per_vehicle, min_half_width)
            self._covers[key] = cover
        return cover

    def relevant(self, vehicle: VehicleObservation, ego_speed_mps: float) -> bool:
        """Whether the vehicle can come near the ego within the horizon (1-D test along the road)."""
        return self._relevance(vehicle, ego_speed_mps) is not None

    def _relevance(self, vehicle: VehicleObservation, ego_speed_mps: float) -> tuple[DiscCover, float] | None:
        """None if not :meth:`relevant`, else (its cover, how far a leader's cover reaches back; 0 otherwise)."""
        c = self.config
        offset = vehicle.offset_m
        if offset > c.range_ahead_m or offset < -c.range_behind_m:
            return None
        if c.ignore_followers_in_lane and vehicle.relation == "behind" and vehicle.relative_lane == 0:
            return None
        # Gap centre-to-centre over t in [0, T] at constant speeds: offset + dv * t. Relevant if it gets within
        # reach: the covered half length plus slack for the ego's own speed changes.
        cover = self._cover(vehicle)
        reach = cover.offsets_m[-1] + cover.radius_m + c.longitudinal_slack_m
        headway = 0.0
        if self._is_leader(vehicle):
            headway = self._headway_m(vehicle, ego_speed_mps)
            reach += headway
        end = offset + (vehicle.speed_mps - ego_speed_mps) * self._horizon_s
        if (offset > 0.0) != (end > 0.0) or min(abs(offset), abs(end)) <= reach:
            return cover, headway
        return None

    @staticmethod
    def _is_leader(vehicle: VehicleObservation) -> bool:
        return vehicle.relative_lane == 0 and vehicle.relation == "ahead"

    def _headway_m(self, vehicle: VehicleObservation, ego_speed_mps: float) -> float:
        """How far the cover of a leader is extended backwards: the following distance, capped so that the
        extended cover still ends 0.5 m in front of the ego's centre (the ego is never inside it)."""
        wanted = self.config.leader_standstill_gap_m
        cover = self._cover(vehicle)
        room = vehicle.offset_m - (cover.offsets_m[-1] + cover.radius_m) - 0.5
        return max(0.0, min(wanted, room))

    def enterable_lanes(self, observation: Observation, target_lane: int | None) -> frozenset[int]:
        """Lanes other than its own the ego may drive into: with ``edges="corridor"`` the lane J1 tracks and
        the tactics' passing lanes, otherwise all. Vehicles there get the lane-entry cover (module docstring)."""
        own = observation.ego.lane_index if observation.ego.lane_role else None
        if self.config.edges == "corridor":
            tracked = frozenset() if target_lane is None else frozenset((target_lane,))
            return (tracked | self._plan.passing_lanes) - {own}
        return frozenset(i for i in range(self.road.lane_count) if i != own)

    def _queue_room(self) -> tuple[Queue, ...]:
        """The queues J0 keeps room behind, out of its time gap (rule ``queue_room``), else none."""
        return self._plan.queues if self._plan.queue_room else ()

    def discs(self, observation: Observation, target_lane: int | None = None) -> tuple[MovingDisc, ...]:
        """Discs of the relevant vehicles, predicted at constant speed along their lanes."""
        self._enterable_lanes = self.enterable_lanes(observation, target_lane)
        ego_speed = observation.ego.speed_mps
        per_lane: dict[int, list[tuple[VehicleObservation, DiscCover, float]]] = {}
        off_road: list[tuple[VehicleObservation, DiscCover, float]] = []
        for vehicle in observation.traffic:
            relevance = self._relevance(vehicle, ego_speed)
            if relevance is None:
                continue
            if vehicle.lane_s_m is None:
                off_road.append((vehicle, *relevance))
            else:
                per_lane.setdefault(vehicle.lane_index, []).append((vehicle, *relevance))
        discs: list[MovingDisc] = []
        if per_lane:
            self._lane_discs(discs, per_lane, ego_speed)
        if off_road and self._other_lanes is not None:
            off_road = self._discs_along_their_lanes(discs, off_road)
        for vehicle, cover, headway in off_road:
            direction = np.array([math.cos(vehicle.heading_rad), math.sin(vehicle.heading_rad)])
            centres = np.array([vehicle.x_m, vehicle.y_m]) + (vehicle.speed_mps * self._steps)[:, None] * direction
            headings = np.ascontiguousarray(np.broadcast_to(direction, centres.shape))
            for offset in self._offsets(vehicle, cover, headway):
                discs.append(MovingDisc(centres + offset * headings if offset else np.ascontiguousarray(centres),
                                        cover.radius_m, headings, self._ego_half_extents_m))
        return tuple(discs)

    def _lane_discs(self, discs: list[MovingDisc],
                    per_lane: dict[int, list[tuple[VehicleObservation, DiscCover, float]]], ego_speed_mps: float) -> None:
        """The discs of the vehicles on lanes, one compiled call per lane (:mod:`agentic_mpc.polylines.kernels`): stage k of
        a disc is the lane point at lane_s + v t_k, plus the vehicle's lateral offset and the disc's offset along its
        heading. Gap acceptance (the tactics' rule): a follower in a passing lane that can let the ego in is
        predicted to, braking at its ``follower_yield_mps2``."""
        gap = self._plan.gap_acceptance
        yield_mps = 0.5 * gap.follower_yield_mps2 * self._horizon_s if gap is not None else 0.0
        for index, lane_items in per_lane.items():
            rows: list[tuple[float, float, float, float, float]] = []  # (speed, lane_s, lateral, offset, heading)
            radii: list[tuple[float, float]] = []  # (the cover's, the bodies')
            yielding = index in self._plan.passing_lanes and yield_mps > 0.0
            for vehicle, cover, headway in lane_items:
                body_radius = self._cover(vehicle, physical=True).radius_m  # what grows with the ego's angle
                speed = vehicle.speed_mps
                if yielding and vehicle.relation == "behind" and gap.lets_in(vehicle.gap_m, speed, ego_speed_mps):
                    speed = max(0.0, speed - yield_mps)
                for offset in self._offsets(vehicle, cover, headway):
                    rows.append((speed, vehicle.lane_s_m, vehicle.lateral_offset_m, offset, vehicle.heading_rad))
                    radii.append((cover.radius_m, body_radius))
            centres, headings = disc_centres(self.road.lane_tables[index], self._steps, np.array(rows, dtype=np.float64))
            discs.extend(MovingDisc(c, radius, h, self._ego_half_extents_m, body)
                         for c, (radius, body), h in zip(centres, radii, headings, strict=True))

    def _discs_along_their_lanes(self, discs: list[MovingDisc], items: list[tuple[VehicleObservation, DiscCover, float]]
                                 ) -> list[tuple[VehicleObservation, DiscCover, float]]:
        """On a route: the discs of vehicles on lanes that are not the road's, their fronts predicted along their own
        lanes and on through the junction the way their routes go (:mod:`agentic_mpc.sumo.lane_tables`), their bodies
        turned as SUMO turns them (:func:`~agentic_mpc.polylines.kernels.body_disc_centres`); returns those on no
        lane (predicted at constant heading)."""
        per_line: dict[int, tuple[Polyline, list[tuple[float, ...]], list[tuple[float, float]]]] = {}
        rest = []
        for vehicle, cover, headway in items:
            placed = self._other_lanes.place(vehicle)
            if placed is None:
                rest.append((vehicle, cover, headway))
                continue
            line, (speed, front_s, lateral, *body) = placed
            _, rows, radii = per_line.setdefault(id(line), (line, [], []))
            body_radius = self._cover(vehicle, physical=True).radius_m
            for offset in self._offsets(vehicle, cover, headway):
                rows.append((speed, front_s, lateral, offset, *body))
                radii.append((cover.radius_m, body_radius))
        for line, rows, radii in per_line.values():
            centres, headings = body_disc_centres(line, self._steps, np.array(rows, dtype=np.float64))
            discs.extend(MovingDisc(c, radius, h, self._ego_half_extents_m, body)
                         for c, (radius, body), h in zip(centres, radii, headings, strict=True))
        return rest

    def _offsets(self, vehicle: VehicleObservation, cover: DiscCover, headway: float) -> tuple[float, ...] | list[float]:
        """The discs' offsets along the vehicle's heading; a leader's row extended backwards by ``headway``."""
        if cover.spacing_m > 0.0 and self._is_leader(vehicle):
            # Extend the row backwards by the following distance, at the spacing that keeps the sides covered.
            rear = cover.offsets_m[0]
            extra = math.ceil(headway / cover.spacing_m)
            step = headway / extra if extra else 0.0
            return [rear - step * n for n in range(extra, 0, -1)] + list(cover.offsets_m)
        return cover.offsets_m

    def leaders(self, observation: Observation, target_lane: int | None) -> tuple[Leader, ...]:
        """The vehicles ahead in the ego's path for J0's time gap (see the module docstring), nearest first."""
        ego = observation.ego
        path_lane = target_lane if target_lane is not None else (ego.lane_index if ego.lane_role else None)
        if path_lane is None:
            return ()
        left, right = self._lane_bounds[path_lane]
        centre, half = 0.5 * (left + right), 0.5 * (left - right)
        table = self.road.lane_tables[path_lane]
        candidates: list[tuple[float, VehicleObservation]] = []
        queued = {member for queue in self._queue_room() for member in queue.members}
        for vehicle in observation.traffic:
            if vehicle.relation != "ahead" or vehicle.lane_s_m is None or vehicle.offset_m > self.config.range_ahead_m:
                continue
            if vehicle.id in queued and (vehicle.relative_lane != 0 or vehicle.gap_m > QUEUE_LEADER_WITHIN_M):
                continue
            if vehicle.lane_index != path_lane:
                if abs(vehicle.lane_index - path_lane) != 1:
                    continue
                vehicle_left, vehicle_right = self._lane_bounds[vehicle.lane_index]
                lateral = 0.5 * (vehicle_left + vehicle_right) - centre + vehicle.lateral_offset_m
                tx, ty = self.road.lane_tables[vehicle.lane_index].tangent(vehicle.lane_s_m)
                lane_heading = math.atan2(ty, tx)
                lateral_speed = vehicle.speed_mps * math.sin(vehicle.heading_rad - lane_heading)
                lateral_then = lateral + lateral_speed * CUT_IN_LOOKAHEAD_S
                if min(abs(lateral), abs(lateral_then)) - 0.5 * vehicle.width_m >= half:
                    continue  # neither reaches into the path lane now nor within the lookahead
            candidates.append((vehicle.gap_m, vehicle))
        if not candidates:
            return ()
        candidates.sort(key=lambda item: item[0])
        in_lane = next((n for n, (_, v) in enumerate(candidates) if v.lane_index == path_lane), len(candidates) - 1)
        chosen = [v for _, v in candidates[: min(in_lane + 1, MAX_LEADERS)]]
        s_ego = locate(table, ego.x_m, ego.y_m, ego.road_s_m)[0]
        ego_s = s_ego + max(ego.speed_mps, 0.0) * self._steps
        h = self.horizon
        arcs = []
        for vehicle in chosen:
            s_vehicle = (vehicle.lane_s_m if vehicle.lane_index == path_lane
                         else locate(table, vehicle.x_m, vehicle.y_m, vehicle.lane_s_m)[0])
            contact = s_vehicle - 0.5 * (vehicle.length_m + self.ego_length_m) + vehicle.speed_mps * self._steps
            arcs += [contact, 0.5 * (contact + ego_s)]  # the tangent halfway is parallel to the chord on an arc
        points, tangents = points_at(table, np.concatenate(arcs))
        return tuple(
            Leader(points[2 * n * h:(2 * n + 1) * h], np.ascontiguousarray(tangents[(2 * n + 1) * h:(2 * n + 2) * h]),
                   self._queue_lateral(observation, vehicle, queued) if vehicle.lane_index == path_lane else None)
            for n, vehicle in enumerate(chosen)
        )

    def _queue_lateral(self, observation: Observation, vehicle: VehicleObservation, queued: set[str]) -> float | None:
        """The leader's cover radius if it drives up to a queue's tail in its lane, else None: J0 then keeps room
        to pull out behind it, rather than follow it into a queue that may never move. Only for a leader in the
        path's lane: one beside that reaches into it is not the car the ego would queue behind (a car creeping
        along the queue's lane beside the ego, aligned to its edge, held the ego standing 10.8 m back in a free
        lane for 15 s: docs/traffic.md)."""
        if vehicle.id in queued or not drives_up_to_a_queue(self._queue_room(), vehicle):
            return None
        return self._cover(vehicle).radius_m

    def corridor(self, observation: Observation, target_lane: int | None) -> tuple[float, float]:
        """(left, right) lateral bounds from the road's centre line of the lanes the ego may use: those its
        box overlaps now, and ``target_lane`` (the lane J1 tracks). The road's edges without a target lane."""
        half = 0.5 * self.road.width_m
        if target_lane is None:
            return half, -half
        lateral = self._ego_lateral_m(observation)
        reach = 0.5 * self.ego_width_m
        left, right = self._lane_bounds[target_lane]
        for lane in self._plan.passing_lanes:
            left, right = max(left, self._lane_bounds[lane][0]), min(right, self._lane_bounds[lane][1])
        for lane_left, lane_right in self._lane_bounds:
            if lateral - reach < lane_left and lateral + reach > lane_right:  # the box overlaps this lane
                left, right = max(left, lane_left), min(right, lane_right)
        return left, right

    def edges(self, road_s_m: float, speed_mps: float, bounds: tuple[float, float] | None = None
              ) -> tuple[TrackingReference, TrackingReference]:
        """Left and right edges where the ego is predicted to be: points ON the edges, travel tangents.

        The edges are the road's centre line shifted sideways (by half the road width, or to ``bounds``),
        sampled at the ego's along-road position advancing at its current speed.
        """
        left, right = bounds if bounds is not None else (0.5 * self.road.width_m, -0.5 * self.road.width_m)
        lines = side_lines(self.road.reference_table, road_s_m, max(speed_mps, 0.0), self._steps, left, right)
        return TrackingReference(lines[0], lines[2]), TrackingReference(lines[1], lines[2])

    def build(self, observation: Observation, ego_state: np.ndarray, target_lane: int | None = None,
              plan: TacticalPlan | None = None) -> Surroundings:
        """Surroundings for a control step from ``ego_state`` = [x, y, phi, v] (SUMO reports the ego where we put
        it); ``target_lane``: the lane J1 tracks; ``plan``: the tactics' plan for this step (None: no tactics)."""
        self._plan = plan = plan if plan is not None else NO_TACTICS
        shift = 0.0
        if plan.followed_lane is not None and target_lane is not None:
            # J1's reference, the corridor, the leaders: of the lane the ego passes in
            shift = self._lane_centres[plan.followed_lane] - self._lane_centres[target_lane]
            target_lane = plan.followed_lane
        left = right = None
        mode = self.config.edges
        if mode != "none":
            bounds = self.corridor(observation, target_lane) if mode == "corridor" else None
            left, right = self.edges(observation.ego.road_s_m, float(ego_state[3]), bounds)
        discs = self.discs(observation, target_lane)
        leaders = self.leaders(observation, target_lane)
        if plan.stop_line_s_m is not None:  # the junction rules stop the ego there: J0 holds it like a car
            leaders = (*leaders, self._stop_line(observation, plan.stop_line_s_m))
        # Queued nose to tail already (the tail is then a time-gap leader): the room behind it is lost, and
        # asking for it made the ego steer and creep into the car (ego_into_stopped at 0.2 m/s, seeds 0-2).
        blockages = tuple(queue.tail for queue in self._queue_room() if not queue.nose_to_tail)
        return Surroundings(moving_discs=discs, road_left_edge=left, road_right_edge=right, leaders=leaders,
                            blockages=blockages, reference_shift_m=shift, reference_speed_cap_mps=plan.speed_cap_mps,
                            lane_lines=self.lane_lines(observation.ego.road_s_m, float(ego_state[3])))

    def _stop_line(self, observation: Observation, stop_s_m: float) -> Leader:
        """A standing leader whose rear is the stop line (along the road's reference line)."""
        ego_s = observation.ego.road_s_m
        contact = np.full(self.horizon, stop_s_m - 0.5 * self.ego_length_m)
        points, tangents = points_at(self.road.reference_table, np.concatenate([contact, 0.5 * (contact + ego_s)]))
        return Leader(points[: self.horizon], np.ascontiguousarray(tangents[self.horizon:]))

    def _ego_lateral_m(self, observation: Observation) -> float:
        """The ego's centre's offset left of the road's reference line (the corridor)."""
        ego = observation.ego
        return locate(self.road.reference_table, ego.x_m, ego.y_m, ego.road_s_m)[1]

    def lane_lines(self, road_s_m: float, speed_mps: float) -> LaneLines | None:
        """The lines between lanes from the ego to past where its plans can end (None with one lane or off)."""
        if not self.config.lane_lines or not self._lines_between_lanes:
            return None
        count = int(math.ceil(max(speed_mps, 0.0) * self._horizon_s / LANE_LINE_SPACING_M)) + LANE_LINE_SPARE_POINTS
        points, tangents = points_at(self.road.reference_table, road_s_m + LANE_LINE_SPACING_M * np.arange(count))
        return LaneLines(points, tangents, LANE_LINE_SPACING_M, self._lines_between_lanes, 0.5 * self.ego_length_m,
                         0.5 * self.ego_width_m)
