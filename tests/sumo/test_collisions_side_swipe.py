"""Our own collision check in real SUMO: the ego steered into the next lane, where a car drives alongside.

SUMO does not see the part of the ego that sticks into the next lane and reports nothing while the ego's
centre is still in its own lane (docs: /work/shared/notes/sumo.md); the footprint check does, once, as the
ego's side swipe.
"""

from __future__ import annotations

from agentic_mpc.run.metrics import MetricsRecorder
from agentic_mpc.sumo.config import EgoStart, SumoConfig, VehicleSpawn
from agentic_mpc.sumo.scenarios import net_files
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.vehicle import throttle_for_steady_speed

NET, ROUTES = net_files("straight")


def test_steering_into_an_occupied_lane_is_the_egos_side_swipe(report):
    neighbour = VehicleSpawn(id="left_car", lane="left", pos_m=100.0, speed_mps=15.0, max_speed_mps=15.0,
                             speed_factor=1.0, imperfection=0.0, lane_changes=False)
    config = SumoConfig(net_file=NET, route_files=(ROUTES,), road="straight", vehicles=(neighbour,),
                        ego=EgoStart(lane="center", pos_m=100.0, speed_mps=15.0))
    metrics = MetricsRecorder()
    with SumoWorld(config) as world:
        throttle = throttle_for_steady_speed(15.0)
        start_lane = world.observation.ego.lane_index
        first_contact = None
        sumo_before_contact = sumo_after_contact = 0
        for _ in range(round(6.0 / world.dt_s)):
            observation = world.advance(0.04, throttle, 0.0)  # a slow drift to the left, no correction
            metrics.observe(observation, world.lateral_offset_m)
            if first_contact is None and metrics.collisions.episodes:
                first_contact = observation
            sumo_reports = sum(c.source == "sumo" for c in observation.collisions)
            if first_contact is None:
                sumo_before_contact += sumo_reports
            else:
                sumo_after_contact += sumo_reports
                if observation.time_s > first_contact.time_s + 1.5:  # SUMO's own reports start meanwhile
                    break
    assert first_contact is not None, "the ego never touched the car in the left lane"
    (episode,) = metrics.collisions.episodes  # in contact for many steps: one episode
    ego = first_contact.ego
    report(f"side swipe at t={episode.time_s:.2f} s: ego lateral offset {ego.lateral_offset_m:.2f} m, "
           f"lane index {ego.lane_index} (start {start_lane}), source {episode.source}; "
           f"SUMO's reports in the 1.5 s after: {sumo_after_contact}")
    assert (episode.other_id, episode.cause, episode.ego_at_fault) == ("left_car", "side_swipe_ego_lane_change", True)
    # found by our check while SUMO saw the ego's centre in its own lane and reported nothing
    assert episode.source == "geometry" and ego.lane_index == start_lane and sumo_before_contact == 0
    # SUMO's own reports once the centre is across belong to the same episode
    assert sumo_after_contact > 0
    assert metrics.collisions.at_fault == 1 and len(metrics.ego_collision_pairs) == 1
