"""The junction rules: how fast the ego may be where, and where it stops (:class:`JunctionDecision`).

- ``speed_zones``: the lanes of the route slower than the road's limit (a turn's internal lanes, a slower edge)
  cap J1's reference speed, braking for them at ``speed_zones.decel_mps2`` ahead of where they begin.
- ``traffic_lights``: red, or yellow when the ego can still stop at ``traffic_lights.yellow_stop_decel_mps2``:
  stop at the line. Green, or a yellow it cannot stop for: go. A yellow it could stop for when it came holds it
  until the light changes: judged anew each step, the stop let go as soon as the ego, still braking gently, needed
  a little more than that rate, and it went through on yellow (``junction_osm_route`` seed 308, t = 236 s).
- ``right_of_way``: at a stop sign stop at the line first; where the ego's movement gives way (a minor road, a
  left turn on green, an all-way stop) it goes only when no vehicle with priority arrives within
  ``right_of_way.gap_s`` and that gap has stayed open ``right_of_way.gap_held_s``. Once its front is past the
  line it stops in the junction only at a waiting point (``JunctionAhead.wait_s_m``, SUMO's internal junction: a
  left turn across oncoming traffic): it goes in when the movements it crosses first are clear and waits there
  for a gap in the ones further in (oncoming traffic), as SUMO's drivers do; on a ten-second green with steady
  oncoming traffic a gap at the line never came (unseen seed 512 stood 110 s, three greens, at one).

A stop is a cap on J1's reference speed that reaches 0 at the line (the speed from which the ego stops at the
rule's rate) and a standing leader at the line for J0's time gap, so the stop holds like one behind a car.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agentic_mpc.tactics.config import TacticsConfig
from agentic_mpc.world.observation import JunctionAhead, Observation

STANDING_MPS = 0.3
"""Slower than this within ``STOPPED_WITHIN_M`` of the line, the ego has stopped there (a stop sign)."""
STOPPED_WITHIN_M = 4.0
GAP_CHECKED_WITHIN_M = 15.0
"""Nearer the line than this, a gap must have stayed open ``right_of_way.gap_held_s`` before the ego goes (a car
that appears from a short lane at the line otherwise meets an ego already moving in)."""


@dataclass(frozen=True, slots=True)
class JunctionDecision:
    """What the junction rules decided this step."""

    speed_cap_mps: float | None = None
    stop_line_s_m: float | None = None
    """Along-road position of the line the ego stops at (its front), None: it does not stop."""
    reason: str | None = None
    """Why, for the agent's situation and ``mpc://tactics`` ("red light at junction J, 23 m ahead")."""


NO_DECISION = JunctionDecision()


class JunctionRules:
    """The three rules over the observation's ``junctions_ahead`` and the road's speed zones (stateful: which
    stop signs the ego has stopped at)."""

    def __init__(self, config: TacticsConfig, speed_zones: tuple[tuple[float, float, float], ...] = (),
                 speed_limit_mps: float = math.inf) -> None:
        self.config = config
        self.speed_zones = speed_zones if config.uses("speed_zones") else ()
        self.speed_limit_mps = speed_limit_mps
        self._stopped_at: set[str] = set()
        self._gap_since: dict[str, float] = {}  # per junction where the ego gives way: since when the gap is open
        self._stops_for_yellow: dict[str, bool] = {}  # per junction with a yellow light: stop decided at its onset

    def decide(self, observation: Observation, ego_length_m: float) -> JunctionDecision:
        front_s = observation.ego.road_s_m + 0.5 * ego_length_m
        speed = observation.ego.speed_mps
        cap, reason = self._zone_cap(front_s)
        for junction in observation.junctions_ahead:  # a yellow is judged when it comes (so is a violation)
            if junction.signal != "yellow":
                self._stops_for_yellow.pop(junction.junction_id, None)
            elif junction.junction_id not in self._stops_for_yellow:
                self._stops_for_yellow[junction.junction_id] = junction.distance_m > 0.0 and self._stoppable(
                    junction, speed)
        for junction in observation.junctions_ahead:
            stop = self._stop_for(junction, speed, observation.time_s)
            if stop is None:
                continue
            why, stop_s = stop
            distance = stop_s - front_s
            rate = self.config.traffic_lights.stop_decel_mps2
            room = max(0.0, distance - self.config.traffic_lights.stop_margin_m)
            stop_cap = math.sqrt(2.0 * rate * room)
            if cap is None or stop_cap <= cap:
                cap, reason = stop_cap, f"{why} at junction {junction.junction_id}, {distance:.0f} m ahead"
            return JunctionDecision(cap, stop_s, reason)
        return JunctionDecision(cap, None, reason) if cap is not None else NO_DECISION

    def _stop_for(self, junction: JunctionAhead, speed_mps: float, time_s: float) -> tuple[str, float] | None:
        """Why the ego stops at this junction and where (its line, or its waiting point inside), or None if it
        goes (the module docstring's rules)."""
        if junction.distance_m < -0.5:  # the front is in the junction: clear it, unless it waits inside
            return self._wait_inside(junction, time_s)
        config = self.config
        if config.uses("traffic_lights") and junction.signal in ("red", "yellow"):
            if junction.signal == "red":
                return "red light", junction.stop_s_m
            if self._stops_for_yellow.get(junction.junction_id) or self._stoppable(junction, speed_mps):
                return "yellow light", junction.stop_s_m
        if not config.uses("right_of_way") or not junction.must_yield:
            return None
        if junction.stop_sign and junction.junction_id not in self._stopped_at:
            if junction.distance_m <= STOPPED_WITHIN_M and speed_mps <= STANDING_MPS:
                self._stopped_at.add(junction.junction_id)
            else:
                return "stop sign", junction.stop_s_m
        arrival = junction.foe_arrival_s
        if arrival is not None and arrival < config.right_of_way.gap_s:
            self._gap_since.pop(junction.junction_id, None)
            return f"giving way (a vehicle with priority arrives in {arrival:.1f} s)", junction.stop_s_m
        since = self._gap_since.setdefault(junction.junction_id, time_s)
        if time_s - since < config.right_of_way.gap_held_s and junction.distance_m < GAP_CHECKED_WITHIN_M:
            return "giving way (checking the gap)", junction.stop_s_m
        # the line is clear: where it waits inside, it comes in at a speed it can stop from there (unseen seed
        # 545 came in at 9.3 m/s, 10 m before its waiting point, with oncoming traffic 2 s away)
        return self._wait_inside(junction, time_s)

    def _wait_inside(self, junction: JunctionAhead, time_s: float) -> tuple[str, float] | None:
        """Inside a junction with a waiting point ahead of the front: wait there while a vehicle with priority
        arrives at the movements crossing the rest of the way within ``right_of_way.gap_s``, and until that gap
        has stayed open ``right_of_way.gap_held_s`` (as at the line: the foe's arrival went missing for one step,
        and the ego set off into its way, tuning seed 502)."""
        if (junction.wait_s_m is None or not self.config.uses("right_of_way") or not junction.must_yield
                or junction.stop_s_m - junction.distance_m > junction.wait_s_m):  # past it: clear the junction
            # (not 0.5 m before it: the ego crept up to its stop and on, the foe 1.4 s away: tuning seed 506)
            return None
        key, arrival = f"{junction.junction_id} inside", junction.inside_foe_arrival_s
        wait_s = junction.wait_s_m
        if arrival is not None and arrival < self.config.right_of_way.gap_s:
            self._gap_since.pop(key, None)
            return f"giving way inside the junction (a vehicle with priority arrives in {arrival:.1f} s)", wait_s
        if time_s - self._gap_since.setdefault(key, time_s) < self.config.right_of_way.gap_held_s:
            return "giving way inside the junction (checking the gap)", wait_s
        return None

    def _stoppable(self, junction: JunctionAhead, speed_mps: float) -> bool:
        """Whether the ego stops at the junction's line braking at ``traffic_lights.yellow_stop_decel_mps2``."""
        needed = speed_mps * speed_mps / (2.0 * max(junction.distance_m, 0.1))
        return needed <= self.config.traffic_lights.yellow_stop_decel_mps2

    def _zone_cap(self, front_s_m: float) -> tuple[float | None, str | None]:
        """The speed the route's slower zones allow here: their limit inside, braking for them ahead."""
        rate = self.config.speed_zones.decel_mps2
        cap: float | None = None
        for start, end, limit in self.speed_zones:
            if end < front_s_m - 10.0:
                continue
            allowed = limit if start <= front_s_m else math.sqrt(limit * limit + 2.0 * rate * (start - front_s_m))
            if cap is None or allowed < cap:
                cap = allowed
            if start > front_s_m + 200.0:
                break
        if cap is None or cap >= self.speed_limit_mps:  # far from every slower zone: no cap to speak of
            return None, None
        return cap, "the route's speed limits (a turn or a slower road) ahead"
