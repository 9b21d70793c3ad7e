"""The junction log's right-of-way check where the ego waits inside a junction (a left turn's waiting point): going
on from the waiting point while a vehicle with priority arrives before the ego has cleared the junction is a
violation; entering while only the oncoming traffic it waits for inside arrives is not."""

from __future__ import annotations

import json
from types import SimpleNamespace

from agentic_mpc.run.junction_log import JunctionLog
from agentic_mpc.world.observation import JunctionAhead


def seen(t: float, front_s_m: float, speed_mps: float, inside_arrival_s: float | None) -> SimpleNamespace:
    """A left turn from s = 100 m to 124 m whose waiting point is 8 m in; the ego's front at ``front_s_m``."""
    junction = JunctionAhead("J", 100.0, 124.0, 100.0 - front_s_m, "left", "green", True, False, None, 108.0,
                             inside_arrival_s)
    return SimpleNamespace(time_s=t, ego=SimpleNamespace(speed_mps=speed_mps), junctions_ahead=(junction,))


def drive(*steps: tuple[float, float, float | None]) -> JunctionLog:
    log = JunctionLog(ego_length_m=5.0)
    for k, (front, speed, arrival) in enumerate(steps):
        log.observe(seen(0.1 * k, front, speed, arrival))
    return log


def test_going_on_from_the_waiting_point_into_oncoming_traffic_is_a_violation_entering_is_not():
    entering = drive((99.5, 3.0, 1.0), (100.5, 3.0, 1.0), (105.0, 1.0, 1.0), (107.5, 0.0, 1.0))
    assert entering.right_of_way_violations == 0  # it went in and waited: the oncoming car had its way
    into_traffic = drive((107.5, 0.0, 1.0), (108.2, 1.0, 1.0))
    assert into_traffic.right_of_way_violations == 1
    row = json.loads(into_traffic.events[-1]["result"])
    assert row["at"] == "waiting point" and row["clear_s"] > 1.0
    in_a_gap = drive((107.5, 0.0, 9.0), (108.2, 1.0, 9.0))
    assert in_a_gap.right_of_way_violations == 0
