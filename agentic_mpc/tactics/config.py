"""The scenario's ``tactics`` section: which rules are in force, each rule's parameters in its own model.

Light on purpose (pydantic only): checking a scenario file loads no simulator and no numpy."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, field_validator

from agentic_mpc.frozen_config import FrozenConfig

RuleName = Literal["queue_room", "passing_lanes", "gap_acceptance", "pass_beside_queue", "pull_out_past_stopped_car",
                   "merge_ahead_of_queue", "speed_zones", "traffic_lights", "right_of_way", "wave_through"]
ALL_RULES: tuple[RuleName, ...] = ("queue_room", "passing_lanes", "gap_acceptance", "pass_beside_queue",
                                   "pull_out_past_stopped_car", "merge_ahead_of_queue", "speed_zones", "traffic_lights",
                                   "right_of_way", "wave_through")
"""Every rule: the blockage rules in the order the lane J1 follows is decided (the first detour rule that starts
wins), then the junction rules (:mod:`agentic_mpc.tactics.junctions`; they act only on routes with junctions)."""


class PassingLanes(FrozenConfig):
    """A blockage this close ahead in the ego's lane or the lane J1 follows opens the lanes beside the ego's: they
    join the corridor and their traffic gets the lane-entry cover, so the ego may go round it there."""

    within_m: float = Field(80.0, ge=0, description="how far ahead a blockage opens the lanes beside")


class GapAcceptance(FrozenConfig):
    """A follower in a passing lane is predicted to brake to let the ego in, if it can (the zipper)."""

    follower_yield_mps2: float = Field(2.0, ge=0, le=9.0, description="how hard it is predicted to brake")
    merge_accel_mps2: float | None = Field(
        2.0, ge=0, description="it yields only if it can, braking at follower_yield_mps2 while the ego speeds up at "
        "this rate (None: every follower yields)")
    standstill_gap_m: float = Field(2.0, ge=0, description="the gap it keeps to the ego when it has let it in")

    def lets_in(self, follower_gap_m: float, follower_speed_mps: float, ego_speed_mps: float) -> bool:
        """Whether a follower this far behind (bumper to bumper) at this speed can let the ego in: its closing
        speed^2 <= 2 x (both rates) x (its gap - the standstill gap). A car at 14 m/s 16 m back was predicted to
        brake clear of the ego pulling out at 1 m/s; it could not, and side-swiped it (seed 3612)."""
        if self.merge_accel_mps2 is None:
            return True
        closing_mps = follower_speed_mps - ego_speed_mps
        braking_mps2 = self.follower_yield_mps2 + self.merge_accel_mps2  # both close the gap
        room_m = max(follower_gap_m - self.standstill_gap_m, 0.0)
        return closing_mps <= 0.0 or closing_mps**2 <= 2.0 * braking_mps2 * room_m


class PassBesideQueue(FrozenConfig):
    """With the ego's centre in the lane beside a blockage of the lane J1 tracks, J1 follows the lane it is in."""

    within_m: float = Field(80.0, ge=0, description="how far ahead the blockage may be")
    lone_obstacle_from_m: float = Field(
        20.0, ge=0, description="beside a lone stopped car (no queue) only from this far back, or standing: nearer, "
        "J2's swerve takes the ego round it, as in the paper")
    standing_mps: float = Field(1.0, ge=0, description="slower than this the ego counts as standing there")


class PullOutPastStoppedCar(FrozenConfig):
    """Standing behind a lone stopped car in the lane J1 tracks, already partly aside: J1 follows the lane on
    that side."""

    aside_m: float = Field(0.25, ge=0, description="how far aside of the car the ego's centre must be")


class MergeAheadOfQueue(FrozenConfig):
    """Driving in the lane J1 tracks towards a queue with cars in it: J1 follows the lane beside (J3's side first),
    so that the ego merges while it moves; not while an emergency vehicle is this close."""

    within_m: float = Field(80.0, gt=0, description="how far ahead the queue's last car may be")


class SpeedZones(FrozenConfig):
    """Lanes of the route slower than the road's limit (a turn, a slower street) cap J1's reference speed."""

    decel_mps2: float = Field(1.5, gt=0, le=5.0, description="how hard the ego brakes for a slower zone ahead")


class TrafficLights(FrozenConfig):
    """Stop at the line for red, and for yellow when the stop is comfortable; go on green."""

    yellow_stop_decel_mps2: float = Field(
        3.0, gt=0, le=9.0, description="yellow: stop if this deceleration or less stops the ego at the line")
    stop_decel_mps2: float = Field(2.0, gt=0, le=9.0, description="the rate the stop's speed cap comes down at")
    stop_margin_m: float = Field(1.0, ge=0, description="the front stops this far before the line")


class RightOfWay(FrozenConfig):
    """Where the ego's movement gives way it goes only in a gap; at a stop sign it stops first."""

    gap_s: float = Field(6.0, gt=0, le=30.0, description="a vehicle with priority arriving sooner holds the ego")
    gap_held_s: float = Field(1.0, ge=0, le=10.0, description="near the line, how long the gap must stay open")


class WaveThrough(FrozenConfig):
    """In a junction, a car standing in the ego's way while the ego stands too is waved on (it goes first)."""

    after_s: float = Field(3.0, ge=0, le=60.0, description="how long both have stood before the ego waves")
    within_m: float = Field(8.0, gt=0, le=30.0, description="how far ahead of the ego's front the car may stand")
    standing_mps: float = Field(0.2, ge=0, le=2.0, description="slower than this counts as standing")


class TacticsConfig(FrozenConfig):
    """The rules in force (by name; a rule left out is off) and their parameters."""

    rules: tuple[RuleName, ...] = Field(ALL_RULES, description="the rules in force, by name")
    passing_lanes: PassingLanes = PassingLanes()
    gap_acceptance: GapAcceptance = GapAcceptance()
    pass_beside_queue: PassBesideQueue = PassBesideQueue()
    pull_out_past_stopped_car: PullOutPastStoppedCar = PullOutPastStoppedCar()
    merge_ahead_of_queue: MergeAheadOfQueue = MergeAheadOfQueue()
    speed_zones: SpeedZones = SpeedZones()
    traffic_lights: TrafficLights = TrafficLights()
    right_of_way: RightOfWay = RightOfWay()
    wave_through: WaveThrough = WaveThrough()

    @field_validator("rules", mode="before")
    @classmethod
    def _known_names(cls, rules: Any) -> Any:
        if isinstance(rules, list | tuple):
            unknown = [rule for rule in rules if rule not in ALL_RULES]
            if unknown:
                raise ValueError(f"unknown tactics {unknown}; the known rules: {', '.join(ALL_RULES)}")
        return rules

    @field_validator("rules")
    @classmethod
    def _each_once(cls, rules: tuple[RuleName, ...]) -> tuple[RuleName, ...]:
        repeated = sorted({rule for rule in rules if rules.count(rule) > 1})
        if repeated:
            raise ValueError(f"rules named twice: {repeated}")
        return rules

    def uses(self, rule: RuleName) -> bool:
        return rule in self.rules
