"""Footprint contact, contact episodes and their causes (agentic_mpc.world.collisions), on scripted motions.

The scripted road is straight along +x with 3.2 m lanes: index 0 (right) at y = -3.2, 1 (centre) at y = 0,
2 (left) at y = 3.2; every car is 4.5 m x 1.8 m. Each observation's collisions come from the shared box check,
as the worlds make them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import pytest

from agentic_mpc.world.collisions import (
    CONTACT_TOLERANCE_M,
    EGO_AT_FAULT,
    CollisionTracker,
    boxes_overlap,
    classify,
    contact_axis,
    footprint_gap_m,
)
from agentic_mpc.world.observation import (
    CollisionObservation,
    EgoObservation,
    Observation,
    ObstacleObservation,
    VehicleObservation,
)

LANE_M, DT_S = 3.2, 0.04
Motion = Callable[[float], tuple[float, float]]
"""t -> (x, y) of a centre."""


@dataclass
class Box:
    x_m: float
    y_m: float
    heading_rad: float = 0.0
    length_m: float = 4.5
    width_m: float = 1.8


# --- geometry ------------------------------------------------------------------------------------------------
def test_touching_boxes_are_in_contact_and_a_centimetre_apart_are_not():
    assert boxes_overlap(Box(0, 0), Box(4.5, 0))  # bumper to bumper
    assert not boxes_overlap(Box(0, 0), Box(4.51, 0))
    assert boxes_overlap(Box(0, 0), Box(1.0, 1.8))  # side to side
    assert not boxes_overlap(Box(0, 0), Box(1.0, 1.81))


def test_rotated_boxes():
    # Crossing at right angles: the other's half length (2.25) reaches sideways.
    assert boxes_overlap(Box(0, 0), Box(0, 0.9 + 2.25 - 0.01, math.pi / 2))
    assert not boxes_overlap(Box(0, 0), Box(0, 0.9 + 2.25 + 0.01, math.pi / 2))
    # 45 degrees off the ego's front-left corner (2.25, 0.9): the nearest corner of the other just in / out.
    half_diagonal = math.hypot(2.25, 0.9)
    for distance, touching in ((half_diagonal - 0.02, True), (half_diagonal + 0.02, False)):
        # the other's corner points at the ego's corner along the diagonal of a 45-degree rotated box
        direction = (math.cos(math.radians(45)), math.sin(math.radians(45)))
        corner = (2.25, 0.9)
        centre = (corner[0] + direction[0] * distance, corner[1] + direction[1] * distance)
        other = Box(*centre, heading_rad=math.atan2(0.9, 2.25) + math.radians(45))
        assert boxes_overlap(Box(0, 0), other) is touching


def test_near_miss_diagonal_and_bounding_circles_overlapping():
    # Bounding circles overlap (centres 4.2 m apart < 4.85 m) but the boxes do not.
    assert not boxes_overlap(Box(0, 0), Box(3.9, 2.6, math.radians(45)))
    assert boxes_overlap(Box(0, 0), Box(3.0, 1.5, math.radians(45)))


def test_contact_axis_from_the_step_before():
    behind = (Box(0, 0), Box(-4.6, 0.3))  # lateral overlap, lengthwise apart
    beside = (Box(0, 0), Box(1.0, 1.9))  # lengthwise overlap, laterally apart
    assert contact_axis(behind, (Box(0, 0), Box(-4.4, 0.3))) == "lengthwise"
    assert contact_axis(beside, (Box(0, 0), Box(1.0, 1.7))) == "sideways"
    # no step before: the smaller penetration now
    assert contact_axis(None, (Box(0, 0), Box(-4.4, 0.3))) == "lengthwise"
    assert contact_axis(None, (Box(0, 0), Box(1.0, 1.7))) == "sideways"


def test_contact_axis_of_a_turned_corner_is_the_one_closing_in():
    # Measured in SUMO (paper_emergency_response, rescue lanes on, yield, seed 0, t = 3.40 and 3.44 s): the
    # 5.2 m x 2.0 m ego, turned 0.13 rad, moves into the lane behind a faster car and clips its rear corner.
    # In the ego's frame both axes overlapped the step before (no decision there); lengthwise the two were
    # drawing apart, sideways closing in.
    def pair(heading: float, ahead: float, left: float, other_heading: float) -> tuple[Box, Box]:
        c, s = math.cos(heading), math.sin(heading)
        return (Box(0.0, 0.0, heading, 5.2, 2.0),
                Box(ahead * c - left * s, ahead * s + left * c, other_heading, 4.5, 1.8))

    before, now = pair(0.127, 4.68, 1.68, 0.006), pair(0.136, 4.89, 1.49, 0.005)
    assert not boxes_overlap(*before) and boxes_overlap(*now)
    assert contact_axis(before, now) == "sideways"


def test_the_box_test_agrees_with_polygon_intersection():
    from shapely.geometry import Polygon

    from agentic_mpc.world.collisions import corners

    def polygon(box: Box) -> Polygon:
        return Polygon(corners(box.x_m, box.y_m, box.heading_rad, box.length_m, box.width_m))

    rng = __import__("random").Random(11)
    overlapping = 0
    for _ in range(3000):
        a = Box(0.0, 0.0, rng.uniform(-math.pi, math.pi), rng.uniform(4, 6), rng.uniform(1.6, 2.2))
        b = Box(rng.uniform(-9, 9), rng.uniform(-6, 6), rng.uniform(-math.pi, math.pi), rng.uniform(4, 12),
                rng.uniform(1.6, 2.6))
        pa, pb = polygon(a), polygon(b)
        if abs(pa.distance(pb)) < 1e-9 and pa.intersection(pb).area < 1e-9:
            continue  # within rounding of touching: either answer is right
        assert boxes_overlap(a, b) is pa.intersects(pb) is boxes_overlap(b, a)
        overlapping += pa.intersects(pb)
    assert 300 < overlapping < 2700  # both outcomes well represented


def test_footprint_gap_is_the_distance_between_the_boxes():
    from shapely.geometry import Polygon

    from agentic_mpc.world.collisions import corners

    def polygon(box: Box) -> Polygon:
        return Polygon(corners(box.x_m, box.y_m, box.heading_rad, box.length_m, box.width_m))

    assert footprint_gap_m(Box(0, 0), Box(5.0, 0)) == pytest.approx(0.5)  # bumper to bumper
    assert footprint_gap_m(Box(0, 0), Box(1.0, 2.3)) == pytest.approx(0.5)  # side by side
    assert footprint_gap_m(Box(0, 0), Box(3.0, 1.5, math.radians(45))) == 0.0  # overlapping
    rng = __import__("random").Random(7)
    for _ in range(500):
        a = Box(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-math.pi, math.pi), rng.uniform(4, 6),
                rng.uniform(1.6, 2.2))
        b = Box(rng.uniform(-8, 8), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi), rng.uniform(4, 12),
                rng.uniform(1.6, 2.6))
        assert footprint_gap_m(a, b) == pytest.approx(polygon(a).distance(polygon(b)), abs=1e-9)


def sumo_report(t: float, gap_m: float) -> Observation:
    """The ego and "car1" side by side in neighbouring lanes (not touching), and SUMO reporting that they collide,
    with the footprint gap the SUMO world measured."""
    ego = EgoObservation("ego", 15.0 * t, 0.0, 0.0, 15.0, "road_1", 1, "", "road", 15.0 * t, 0.0, 4.5, 1.8)
    report = CollisionObservation("ego", "car1", "ego", "car", 15.0, 17.0, "collision", "road_1", 0.0, True, "sumo",
                                  gap_m)
    return Observation(round(t, 9), ego, (), (), (), (report,))


def test_a_sumo_report_the_footprints_do_not_confirm_is_kept_apart_not_counted():
    # Measured on the curved road (rescue-lane traffic, yield, seed 300): SUMO reported the ego striking a car
    # it passed behind, the boxes 0.35 m apart at their closest and 1.26 m when SUMO reported it.
    tracker = CollisionTracker()
    for k, gap in enumerate((1.26, 1.5, 1.9)):
        tracker.update(sumo_report(k * DT_S, gap))
    tracker.update(sumo_report(3.0, 0.9))  # a second report of the same pair, long after: a record of its own
    assert tracker.episodes == [] and tracker.at_fault == 0
    assert [(r.other_id, r.other_type, r.time_s, r.min_gap_m) for r in tracker.reports_without_contact] == [
        ("car1", "car", 0.0, 1.26), ("car1", "car", 3.0, 0.9)]
    assert not sumo_report(0.0, 1.26).ego_collided


def test_a_sumo_report_within_the_tolerance_or_unmeasured_is_a_collision():
    for gap in (0.0, CONTACT_TOLERANCE_M, float("nan")):
        tracker = CollisionTracker()
        tracker.update(sumo_report(0.0, gap))
        assert [(e.other_id, e.source) for e in tracker.episodes] == [("car1", "sumo")]
        assert tracker.reports_without_contact == []


def test_a_report_without_contact_that_turns_into_contact_is_one_collision():
    tracker = CollisionTracker()
    tracker.update(sumo_report(0.0, 0.3))
    tracker.update(sumo_report(DT_S, 0.05))
    assert [e.time_s for e in tracker.episodes] == [DT_S] and tracker.reports_without_contact == []


# --- scripted observations -----------------------------------------------------------------------------------
def lane_of(y_m: float) -> tuple[int, float]:
    index = round(y_m / LANE_M) + 1
    return index, y_m - (index - 1) * LANE_M


def speed_and_heading(motion: Motion, t: float) -> tuple[float, float]:
    (x0, y0), (x1, y1) = motion(t), motion(t + 1e-3)
    return math.hypot(x1 - x0, y1 - y0) / 1e-3, math.atan2(y1 - y0, x1 - x0)


def observe(t: float, ego: Motion, others: dict[str, Motion], obstacles: dict[str, tuple[float, float]] | None = None
            ) -> Observation:
    x, y = ego(t)
    speed, heading = speed_and_heading(ego, t)
    index, lateral = lane_of(y)
    ego_obs = EgoObservation("ego", x, y, heading, speed, f"road_{index}", index, "", "road", x, lateral, 4.5, 1.8)
    traffic = []
    for other_id, motion in others.items():
        ox, oy = motion(t)
        o_speed, o_heading = speed_and_heading(motion, t)
        o_index, o_lateral = lane_of(oy)
        offset = ox - x
        gap = abs(offset) - 4.5
        traffic.append(VehicleObservation(
            other_id, "car", "passenger", ox, oy, o_heading, o_speed, o_speed * math.cos(o_heading),
            o_speed * math.sin(o_heading), f"road_{o_index}", o_index, "", "road", 4.5, 1.8, ox, offset, gap,
            "alongside" if gap < 0 else ("ahead" if offset > 0 else "behind"), o_index - index, ox, o_lateral, "", 0.0))
    stopped = []
    for obstacle_id, (ox, oy) in (obstacles or {}).items():
        o_index, _ = lane_of(oy)
        offset = ox - x
        stopped.append(ObstacleObservation(obstacle_id, "car", ox, oy, 0.0, 4.5, 1.8, f"road_{o_index}", o_index, "",
                                           ox, offset, abs(offset) - 4.5, "ahead", o_index - index))
    collisions = tuple(
        CollisionObservation("ego", other.id, "ego", other.type_id, speed, getattr(other, "speed_mps", 0.0),
                             "overlap", ego_obs.lane_id, x, True, "geometry", 0.0)
        for other in (*traffic, *stopped) if boxes_overlap(ego_obs, other)
    )
    return Observation(round(t, 9), ego_obs, tuple(traffic), (), tuple(stopped), collisions)


def run(ego: Motion, others: dict[str, Motion], until_s: float,
        obstacles: dict[str, tuple[float, float]] | None = None) -> CollisionTracker:
    tracker = CollisionTracker()
    for k in range(round(until_s / DT_S) + 1):
        tracker.update(observe(k * DT_S, ego, others, obstacles))
    return tracker


def straight(x0: float, speed: float, y: float = 0.0) -> Motion:
    return lambda t: (x0 + speed * t, y)


def causes(tracker: CollisionTracker) -> list[tuple[str, str]]:
    return [(e.other_id, e.cause) for e in tracker.episodes]


# --- causes --------------------------------------------------------------------------------------------------
def test_a_faster_follower_in_the_ego_lane_rear_ends_it_once():
    # It drives right through the ego (nothing brakes here): one contact episode of about 0.9 s.
    tracker = run(straight(0.0, 15.0), {"follower": straight(-20.0, 25.0)}, until_s=4.0)
    assert causes(tracker) == [("follower", "rear_ended")]
    (episode,) = tracker.episodes
    assert episode.time_s == pytest.approx(1.56, abs=DT_S) and not episode.ego_at_fault and tracker.at_fault == 0


def test_the_ego_striking_the_slower_car_ahead():
    tracker = run(straight(0.0, 15.0), {"leader": straight(20.0, 10.0, y=0.3)}, until_s=4.0)
    assert causes(tracker) == [("leader", "ego_struck_leader")] and tracker.at_fault == 1


def test_a_car_ahead_coming_back_into_the_standing_ego_struck_it():
    """Lengthwise contact with a car ahead is the ego's fault only if the ego moved: a U-turning car's rear swung
    into an ego that had stood (tuning seed 508 of the OpenStreetMap route), here a car reversing into it."""
    tracker = run(straight(0.0, 0.0), {"reversing": lambda t: (10.0 - 3.0 * t, 0.2)}, until_s=3.0)
    assert causes(tracker) == [("reversing", "struck_standing_ego")] and tracker.at_fault == 0
    moving = run(straight(0.0, 2.0), {"reversing": lambda t: (10.0 - 3.0 * t, 0.2)}, until_s=3.0)
    assert causes(moving) == [("reversing", "ego_struck_leader")]


def test_the_ego_drifting_into_the_occupied_left_lane_is_its_side_swipe():
    # 1 m/s to the left; contact at y = 1.4, while the ego's centre is still in its own lane (as SUMO sees it).
    ego: Motion = lambda t: (15.0 * t, min(1.0 * t, 2.0))
    tracker = run(ego, {"left_car": straight(1.0, 15.0, y=LANE_M)}, until_s=3.0)
    assert causes(tracker) == [("left_car", "side_swipe_ego_lane_change")] and tracker.at_fault == 1
    # At 3.8 degrees of heading its front corner touches first: y = 1.28 m, the centre still in its own lane.
    assert tracker.episodes[0].time_s == pytest.approx(1.28, abs=DT_S)


def test_a_car_changing_lane_into_the_ego_at_once_is_its_side_swipe():
    # SUMO without sublane: the lane change is instant (lane index and position jump in one step).
    other: Motion = lambda t: (15.0 * t + 1.0, LANE_M if t < 1.0 else 0.5)
    tracker = run(straight(0.0, 15.0), {"cutter": other}, until_s=2.0)
    assert causes(tracker) == [("cutter", "side_swipe_other_lane_change")] and tracker.at_fault == 0


def test_a_car_drifting_into_the_ego_within_its_lane_is_its_side_swipe():
    # Sublane style: no lane index change before contact, a lateral speed toward the ego of 0.8 m/s.
    other: Motion = lambda t: (15.0 * t - 1.0, LANE_M - 0.8 * t)
    tracker = run(straight(0.0, 15.0), {"drifter": other}, until_s=2.5)
    assert causes(tracker) == [("drifter", "side_swipe_other_lane_change")]


def test_the_one_moving_sideways_is_at_fault_even_if_the_other_sits_further_over():
    # The ego holds 1.2 m left of its lane centre; the other drifts right from 0.3 m left of its own centre and
    # touches at -0.2 m: it sits less far over than the ego, but its lateral motion closed the gap.
    other: Motion = lambda t: (15.0 * t + 1.0, LANE_M + 0.3 - 0.8 * t)
    tracker = run(straight(0.0, 15.0, y=1.2), {"drifter": other}, until_s=2.0)
    assert causes(tracker) == [("drifter", "side_swipe_other_lane_change")] and tracker.at_fault == 0


def test_both_straight_the_one_sticking_over_is_at_fault():
    # The ego holds 1.45 m left of its lane centre (0.75 m into the next lane); a faster car there clips it.
    tracker = run(straight(0.0, 15.0, y=1.45), {"passer": straight(-20.0, 25.0, y=LANE_M)}, until_s=4.0)
    assert causes(tracker) == [("passer", "side_swipe_ego_lane_change")] and tracker.at_fault == 1
    # The same with the passer sticking over to the right instead: not the ego's fault.
    tracker = run(straight(0.0, 15.0), {"passer": straight(-20.0, 25.0, y=LANE_M - 1.45)}, until_s=4.0)
    assert causes(tracker) == [("passer", "side_swipe_other_lane_change")] and tracker.at_fault == 0


def test_into_an_obstacle_or_a_stopped_car():
    tracker = run(straight(0.0, 15.0), {}, until_s=3.0, obstacles={"broken_down": (30.0, 0.2)})
    assert causes(tracker) == [("broken_down", "ego_into_stopped")] and tracker.at_fault == 1
    tracker = run(straight(0.0, 15.0), {"parked": straight(30.0, 0.0, y=-0.3)}, until_s=3.0)
    assert causes(tracker) == [("parked", "ego_into_stopped")] and tracker.at_fault == 1


# --- episodes ------------------------------------------------------------------------------------------------
def test_contact_gaps_shorter_than_the_separation_are_one_episode_longer_ones_two():
    tracker = CollisionTracker()
    side = {"side": straight(1.0, 15.0, y=LANE_M)}
    over, back = straight(0.0, 15.0, y=1.45), straight(0.0, 15.0, y=0.4)  # the ego over the line or back
    # in contact 0-0.4 s, apart one step, in contact again, apart 1 s, in contact again
    schedule = [over] * 10 + [back] + [over] * 10 + [back] * 25 + [over] * 5
    started = [len(tracker.update(observe(k * DT_S, ego, side))) for k, ego in enumerate(schedule)]
    assert sum(started) == 2 == len(tracker.episodes)
    assert started[0] == 1 and started[46] == 1
    assert [e.cause for e in tracker.episodes] == ["side_swipe_ego_lane_change"] * 2 and tracker.at_fault == 2


def test_several_vehicles_each_their_own_episode_and_fault():
    tracker = run(straight(0.0, 15.0), {"follower": straight(-20.0, 25.0), "leader": straight(40.0, 5.0, y=0.2)},
                  until_s=4.0)
    assert sorted(causes(tracker)) == [("follower", "rear_ended"), ("leader", "ego_struck_leader")]
    assert tracker.at_fault == 1


def test_a_sumo_report_without_the_other_in_view_uses_sumos_collider():
    ego = EgoObservation("ego", 0.0, 0.0, 0.0, 10.0, "road_1", 1, "", "road", 0.0, 0.0, 4.5, 1.8)
    report = CollisionObservation("car9", "ego", "car", "ego", 20.0, 10.0, "collision", "road_1", 0.0, True, "sumo",
                                  float("nan"))
    observation = Observation(0.0, ego, (), (), (), (report,))
    assert classify([observation], "car9") == "rear_ended"
    tracker = CollisionTracker()
    (episode,) = tracker.update(observation)
    assert (episode.other_id, episode.other_type, episode.source, episode.other_speed_mps) == ("car9", "car", "sumo",
                                                                                               20.0)


def test_the_fault_rule():
    assert EGO_AT_FAULT == {"ego_struck_leader", "side_swipe_ego_lane_change", "ego_into_stopped"}


def test_the_plain_world_uses_the_shared_box_check():
    from agentic_mpc.vehicle import throttle_for_steady_speed
    from agentic_mpc.world.plain import PlainWorld
    from agentic_mpc.world.plain_config import PlainConfig, ScriptedVehicle

    # A car (observed as a 4 m square: radius 2) alongside in the left lane (y = 3.5); the ego drifts left.
    world = PlainWorld(PlainConfig(vehicles=(ScriptedVehicle(id="car0", lane="left", x_m=1.0,
                                                             desired_speed_mps=15.0),)))
    tracker, throttle = CollisionTracker(), throttle_for_steady_speed(15.0)
    first = None
    while world.time_s < 4.0 and first is None:
        observation = world.advance(0.03, throttle, 0.0)
        if tracker.update(observation):
            first = observation
    assert first is not None
    car = first.vehicle("car0")
    # Touching sideways: the centres 0.9 + 2.0 m apart plus what the ego's turned front corner gains (the old
    # disc check, 1.5 + 2.0 m, fired 0.5 m earlier); its centre still in its own lane.
    corner_m = 2.25 * math.sin(first.ego.heading_rad)
    assert 2.85 < car.y_m - first.ego.y_m <= 2.9 + corner_m + 1e-9 and first.ego.lane_role == "center"
    assert causes(tracker) == [("car0", "side_swipe_ego_lane_change")] and tracker.at_fault == 1
