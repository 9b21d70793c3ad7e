"""The tactics layer: between what the world observes and the controller, the run loop asks it every control step
which lane J1 follows, which lanes open for passing, where J0 keeps room behind a queue and which followers are
predicted to let the ego in (:class:`TacticalPlan`). The world's surroundings builder turns the plan into J0's
discs, corridor and queue room; what a tactic changes is shown to the agent (``mpc://tactics``, a line of its
situation) and to the user (``events.csv`` rows ``tactic_started`` / ``tactic_ended``, the replay's captions).

It knows worlds only through the observation and a :class:`TacticalRoad` (no simulator), so any world that
offers one gets the same rules. docs/traffic.md says what each rule does and why."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from agentic_mpc.tactics.config import GapAcceptance, TacticsConfig
from agentic_mpc.tactics.covers import disc_cover
from agentic_mpc.tactics.detour import Detour, Passing
from agentic_mpc.tactics.junctions import JunctionDecision, JunctionRules
from agentic_mpc.tactics.queues import Queue, find_queues
from agentic_mpc.tactics.road import TacticalRoad
from agentic_mpc.tactics.wave_through import NEAR_LINE_M, Waved, WaveThrough
from agentic_mpc.world.observation import Observation


@dataclass(frozen=True, slots=True)
class ActiveTactic:
    """A tactic that changes J1's reference: the lane it follows instead of the tracked one, since when, past what."""

    rule: str
    obstacle_id: str
    tracked_lane: int
    followed_lane: int
    since_s: float

    def to_json(self) -> dict[str, Any]:
        return {"rule": self.rule, "obstacle_id": self.obstacle_id, "tracked_lane": self.tracked_lane,
                "followed_lane": self.followed_lane, "since_s": round(self.since_s, 3)}

    def describe(self) -> str:
        return (f"tactic {self.rule}: J1 follows lane {self.followed_lane} instead of lane {self.tracked_lane} "
                f"to pass {self.obstacle_id} (since t={self.since_s:.1f} s)")


@dataclass(frozen=True, slots=True)
class TacticalPlan:
    """What the tactics decided for one control step."""

    queues: tuple[Queue, ...] = ()
    """The blockages ahead (every rule reads them)."""
    queue_room: bool = False
    """J0 keeps room to pull out behind each queue's last car (rule ``queue_room``)."""
    passing_lanes: frozenset[int] = frozenset()
    """The lanes beside the ego's opened by a blockage (rule ``passing_lanes``)."""
    gap_acceptance: GapAcceptance | None = None
    """Followers in the passing lanes that can let the ego in are predicted to (rule ``gap_acceptance``)."""
    followed_lane: int | None = None
    """The lane J1 follows instead of the tracked one (None: the tracked one)."""
    active: ActiveTactic | None = None
    speed_cap_mps: float | None = None
    """A cap on J1's reference speed (the junction rules: a slower zone ahead, a stop at a line)."""
    stop_line_s_m: float | None = None
    """Along-road position of the line the ego's front stops at (J0 holds it there like a standing car)."""
    junction_reason: str | None = None
    """Why the junction rules cap the speed or stop the ego (for the agent)."""
    wave_through: str | None = None
    """A car standing in the ego's way in a junction that the ego waves on this step (rule ``wave_through``):
    the world tells its driver to go first."""


NO_TACTICS = TacticalPlan()


@dataclass
class TacticsLayer:
    """The rules of ``config`` over a world's ``road`` (see the module docstring). One per run: a detour lasts."""

    config: TacticsConfig
    road: TacticalRoad
    active: ActiveTactic | None = None
    changes: list[dict[str, Any]] = field(default_factory=list)
    """``events.csv`` rows of tactics that started or ended, in order."""

    def __post_init__(self) -> None:
        self._detour = Detour(self.config)
        self._junction_rules = JunctionRules(self.config, self.road.speed_zones, self.road.speed_limit_mps)
        self._wave_through = WaveThrough(self.config)
        self.junction_reason: str | None = None
        self._queues_of: Observation | None = None
        self._queues: tuple[Queue, ...] = ()

    def retarget(self, road: TacticalRoad) -> None:
        """The ego's road changed (another route): the rules read the new one from the next step."""
        self.road = road
        self._junction_rules = JunctionRules(self.config, road.speed_zones, road.speed_limit_mps)

    def queues(self, observation: Observation) -> tuple[Queue, ...]:
        """Each static obstacle ahead with the vehicles standing behind it in its lane (physical covers)."""
        if self._queues_of is observation:
            return self._queues
        road = self.road

        def cover(length_m: float, width_m: float, max_discs: int = 8) -> Any:
            return disc_cover(length_m, width_m, road.ego_length_m, road.ego_width_m, road.clearance_margin_m,
                              max_discs)

        self._queues = find_queues(
            observation, lambda v: cover(v.length_m, v.width_m, road.max_discs_per_vehicle),
            lambda o: cover(o.length_m, o.width_m), road.range_ahead_m) if self.config.rules else ()
        self._queues_of = observation
        return self._queues

    def plan(self, observation: Observation, tracked_lane: int | None, passing_side: str | None = None) -> TacticalPlan:
        """The plan for this step: ``tracked_lane`` is the lane J1 tracks (None: no path), ``passing_side`` J3's."""
        config = self.config
        queues = self.queues(observation)
        followed = self._detour.lane(observation, queues, tracked_lane, self.road.lane_centres_m, passing_side)
        self._note(self._detour.passing if followed is not None else None, observation.time_s)
        lane = followed if followed is not None else tracked_lane
        junction = self._junction_rules.decide(observation, self.road.ego_length_m)
        front_s = observation.ego.road_s_m + 0.5 * self.road.ego_length_m
        at_line = junction.stop_line_s_m is not None and junction.stop_line_s_m - front_s <= NEAR_LINE_M
        waved = self._wave_through.decide(observation, self.road, lane, at_line)
        if waved is not None:
            self.changes.append(_waved_event(waved))
        last = self._wave_through.last  # the ego stands where it is for a car it waved on or one crossing
        if not at_line and self._wave_through.hold(observation, self.road, lane) and last is not None:
            junction = JunctionDecision(0.0, front_s, last.describe())
        elif not at_line and (crossing := self._wave_through.crossing(observation, self.road, lane)) is not None:
            junction = JunctionDecision(0.0, front_s, f"waiting for {crossing.id} to cross in front")
        self.junction_reason = junction.reason
        return TacticalPlan(
            queues=queues, queue_room=config.uses("queue_room"),
            passing_lanes=self._passing_lanes(observation, queues, lane),
            gap_acceptance=config.gap_acceptance if config.uses("gap_acceptance") else None,
            followed_lane=followed, active=self.active, speed_cap_mps=junction.speed_cap_mps,
            stop_line_s_m=junction.stop_line_s_m, junction_reason=junction.reason,
            wave_through=waved.vehicle_id if waved is not None else None)

    def _passing_lanes(self, observation: Observation, queues: tuple[Queue, ...], lane: int | None) -> frozenset[int]:
        """The lanes beside the ego's when a blockage stands ahead in the lane it drives or follows, its tail
        within ``passing_lanes.within_m``: where the ego goes round."""
        ego = observation.ego
        if not self.config.uses("passing_lanes") or not ego.lane_role:
            return frozenset()
        within = self.config.passing_lanes.within_m
        lanes = {ego.lane_index} | ({lane} if lane is not None else set())
        if not any(q.lane_index in lanes and q.tail_gap_m <= within for q in queues):
            return frozenset()
        own = ego.lane_index
        return frozenset(i for i in (own - 1, own + 1) if 0 <= i < len(self.road.lane_centres_m))

    def _note(self, passing: Passing | None, time_s: float) -> None:
        """Keep :attr:`active` and an event row for each tactic that starts or ends."""
        before = self.active
        key = None if passing is None else (passing.rule, passing.obstacle_id, passing.tracked_lane,
                                            passing.followed_lane)
        if before is not None and key == (before.rule, before.obstacle_id, before.tracked_lane, before.followed_lane):
            return
        if before is not None:
            self.changes.append(_event("tactic_ended", before, time_s))
        self.active = None if passing is None else ActiveTactic(*key, since_s=time_s)  # type: ignore[misc]
        if self.active is not None:
            self.changes.append(_event("tactic_started", self.active, time_s))

    def to_json(self) -> dict[str, Any]:
        """The resource ``mpc://tactics``: the rules in force and the tactic changing J1's reference, if any."""
        state = {"rules": list(self.config.rules), "active": self.active.to_json() if self.active else None}
        return {**state, "junction": self.junction_reason} if self.junction_reason else state

    def situation(self) -> str | None:
        """A line for the agent's situation while a tactic changes J1's reference or a junction rule holds the
        ego's speed."""
        lines = [self.active.describe()] if self.active is not None else []
        if self.junction_reason:
            lines.append(f"junction rules: {self.junction_reason}")
        return "; ".join(lines) or None


def _waved_event(waved: Waved) -> dict[str, Any]:
    return {"event": "waved_through", "sim_time_s": round(waved.time_s, 3), "tau": None, "source": "tactics",
            "content": waved.vehicle_id, "result": json.dumps({"rule": "wave_through", "vehicle_id": waved.vehicle_id,
                                                              "junction_id": waved.junction_id})}


def _event(kind: str, tactic: ActiveTactic, time_s: float) -> dict[str, Any]:
    return {"event": kind, "sim_time_s": round(time_s, 3), "tau": None, "source": "tactics", "content": tactic.rule,
            "result": json.dumps(tactic.to_json())}
