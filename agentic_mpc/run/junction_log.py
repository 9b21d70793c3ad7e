"""How the ego went through the junctions of its route: ``events.csv`` rows and ``summary.csv`` columns.

- ``junction_entered``: the ego's front crossed a junction's stop line (the light, whether it gave way, how soon
  a vehicle with priority arrived, its speed);
- ``junction_passed``: its front left the junction;
- ``red_light_violation``: it crossed on red, or on a yellow that came while a stop at ``YELLOW_STOP_MPS2`` was
  still possible;
- ``right_of_way_violation``: it entered where it gives way (or went on from a waiting point inside) while a
  vehicle with priority would arrive before the ego had cleared the junction, speeding up from its speed at
  ``CLEARING_ACCEL_MPS2``.
``stopped_at_lights_s``: the time standing at a red or yellow light (its front within ``AT_LINE_M`` of the line).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

from agentic_mpc.world.observation import JunctionAhead, Observation

YELLOW_STOP_MPS2 = 3.0
AT_LINE_M = 30.0
STANDING_MPS = 0.3
CLEARING_ACCEL_MPS2 = 2.0


@dataclass
class JunctionLog:
    """Per-step bookkeeping of the junctions ahead (:class:`~agentic_mpc.world.observation.JunctionAhead`)."""

    ego_length_m: float = 5.0
    events: list[dict[str, Any]] = field(default_factory=list)
    passed: int = 0
    red_light_violations: int = 0
    right_of_way_violations: int = 0
    stopped_at_lights_s: float = 0.0
    _last: dict[str, JunctionAhead] = field(default_factory=dict)
    _stoppable_yellow: dict[str, bool] = field(default_factory=dict)
    """Per junction: whether the ego could have stopped when its light turned yellow (this yellow)."""
    _time_s: float | None = None

    @property
    def junction_ids_ahead(self) -> tuple[str, ...]:
        """The junctions the last observation had ahead (their passing is noted when they are gone)."""
        return tuple(self._last)

    def observe(self, observation: Observation) -> None:
        ego = observation.ego
        dt = 0.0 if self._time_s is None else observation.time_s - self._time_s
        self._time_s = observation.time_s
        now = {j.junction_id: j for j in observation.junctions_ahead}
        for junction in observation.junctions_ahead:
            if junction.signal == "yellow" and junction.junction_id not in self._stoppable_yellow:
                needed = ego.speed_mps**2 / (2.0 * max(junction.distance_m, 0.01))
                self._stoppable_yellow[junction.junction_id] = junction.distance_m > 0.0 and needed <= YELLOW_STOP_MPS2
            elif junction.signal != "yellow":
                self._stoppable_yellow.pop(junction.junction_id, None)
            before = self._last.get(junction.junction_id)
            if before is not None and before.distance_m >= 0.0 > junction.distance_m:
                self._entered(before, junction, observation)
            if before is not None and before.wait_s_m is not None and (
                    before.stop_s_m - before.distance_m < before.wait_s_m <= junction.stop_s_m - junction.distance_m):
                self._went_on(before, observation)
        first = observation.junctions_ahead[0] if observation.junctions_ahead else None
        if (first is not None and first.signal in ("red", "yellow") and 0.0 <= first.distance_m <= AT_LINE_M
                and ego.speed_mps < STANDING_MPS):
            self.stopped_at_lights_s += dt
        for junction_id, before in self._last.items():
            if junction_id not in now and before.distance_m < 0.0:  # its front left the junction
                self.passed += 1
                self.events.append(self._row("junction_passed", before, observation, {}))
        self._last = now

    def _entered(self, before: JunctionAhead, junction: JunctionAhead, observation: Observation) -> None:
        speed = observation.ego.speed_mps
        facts: dict[str, Any] = {"signal": before.signal, "must_yield": before.must_yield,
                                 "foe_arrival_s": before.foe_arrival_s, "speed_mps": round(speed, 2)}
        self.events.append(self._row("junction_entered", junction, observation, facts))
        if before.signal == "red" or (before.signal == "yellow" and self._stoppable_yellow.get(before.junction_id)):
            self.red_light_violations += 1
            self.events.append(self._row("red_light_violation", junction, observation, facts))
        self._check_way(before, before.stop_s_m, before.foe_arrival_s, junction, observation, facts)

    def _went_on(self, before: JunctionAhead, observation: Observation) -> None:
        """The front passed the junction's waiting point: the movements it waited for there are checked."""
        facts = {"at": "waiting point", "foe_arrival_s": before.inside_foe_arrival_s,
                 "speed_mps": round(observation.ego.speed_mps, 2)}
        self._check_way(before, before.wait_s_m, before.inside_foe_arrival_s, before, observation, facts)

    def _check_way(self, before: JunctionAhead, from_s_m: float | None, arrival_s: float | None,
                   junction: JunctionAhead, observation: Observation, facts: dict[str, Any]) -> None:
        """A right-of-way violation if a vehicle with priority arrived before the ego, from ``from_s_m`` at its
        speed now, had its rear out of the junction."""
        speed = observation.ego.speed_mps
        way_m = before.exit_s_m - (from_s_m or before.stop_s_m) + self.ego_length_m
        clear_s = (-speed + math.sqrt(speed * speed + 2.0 * CLEARING_ACCEL_MPS2 * way_m)) / CLEARING_ACCEL_MPS2
        if before.must_yield and arrival_s is not None and arrival_s < clear_s:
            self.right_of_way_violations += 1
            self.events.append(self._row("right_of_way_violation", junction, observation,
                                         {**facts, "clear_s": round(clear_s, 2)}))

    @staticmethod
    def _row(kind: str, junction: JunctionAhead, observation: Observation, facts: dict[str, Any]) -> dict[str, Any]:
        return {"event": kind, "sim_time_s": round(observation.time_s, 3), "tau": None, "source": "world",
                "content": junction.junction_id, "result": json.dumps({"direction": junction.direction, **facts})}

    def summary(self, route_completed: bool) -> dict[str, Any]:
        return {"route_completed": route_completed, "junctions_passed": self.passed,
                "red_light_violations": self.red_light_violations,
                "right_of_way_violations": self.right_of_way_violations,
                "stopped_at_lights_s": round(self.stopped_at_lights_s, 3)}
