"""The part of the ego that sticks into the next lane, shown to SUMO (agentic_mpc.sumo.outline): the geometry, and
SUMO's drivers in that lane going round it instead of through it. Real SUMO (libsumo)."""

from __future__ import annotations

import math

import pytest

from agentic_mpc.sumo.config import EgoStart, SumoConfig
from agentic_mpc.sumo.outline import MIN_DEPTH_M, protrusion
from agentic_mpc.sumo.scenarios import net_files, nets_dir
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.world.collisions import boxes_overlap, footprint_gap_m

# Three 3.5 m lanes of a right-hand road, (left, right) lines from its centre line by lane index (0: rightmost).
LANES = ((-1.75, -5.25), (1.75, -1.75), (5.25, 1.75))


def box(s_m: float, lateral_m: float, heading_rad: float = 0.0, length_m: float = 5.2, width_m: float = 2.0
        ) -> list[tuple[float, float]]:
    """The corners (s, lateral) of a box on a straight road, in order round it."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return [(s_m + a * c - b * s, lateral_m + a * s + b * c)
            for a, b in ((length_m / 2, width_m / 2), (-length_m / 2, width_m / 2),
                         (-length_m / 2, -width_m / 2), (length_m / 2, -width_m / 2))]


def test_the_protrusion_is_the_part_of_the_box_beyond_its_lanes_line():
    # 1.2 m left of the centre lane's middle: 0.45 m into the left lane, along the whole box.
    part = protrusion(box(100.0, 1.2), 1.2, LANES)
    assert part.lane_index == 2 and (part.inner_m, part.outer_m) == pytest.approx((1.75, 2.2))
    assert (part.rear_s_m, part.front_s_m) == pytest.approx((97.4, 102.6))
    # Right of the middle: into the right lane (lane 0), measured to the right.
    part = protrusion(box(100.0, -1.5), -1.5, LANES)
    assert part.lane_index == 0 and part.depth_m == pytest.approx(0.75) and part.outer_m == pytest.approx(-2.5)
    # Turned 0.3 rad to the left, 0.3 m left of the middle: only the front left corner is over the line; the part
    # runs from where the box's left side crosses it to where its front crosses it.
    front_left, _, _, front_right = box(100.0, 0.3, 0.3)
    part = protrusion(box(100.0, 0.3, 0.3), 0.3, LANES)
    assert part.lane_index == 2 and part.outer_m == pytest.approx(front_left[1])
    assert front_left[0] < part.front_s_m < front_right[0] and 97.4 < part.rear_s_m < front_left[0]
    # Inside the lane, shallower than MIN_DEPTH_M, over the road's edge, or off every lane: nothing.
    assert protrusion(box(100.0, 0.0), 0.0, LANES) is None
    assert protrusion(box(100.0, 0.75 + 0.5 * MIN_DEPTH_M), 0.75 + 0.5 * MIN_DEPTH_M, LANES) is None
    assert protrusion(box(100.0, 4.7), 4.7, LANES) is None
    assert protrusion(box(100.0, 6.0), 6.0, LANES) is None


def passing_car(show_outline: bool) -> tuple[float, float]:
    """The ego stands in the centre lane 1.7 m left of its middle (0.95 m into the left lane); a car comes up the
    left lane from 60 m behind at 15 m/s. Returns the closest the car's and the ego's footprints came in 8 s (m;
    -1: overlapping) and whether the car got past the ego."""
    net, _ = net_files("curvy", False)
    config = SumoConfig(net_file=net, route_files=(nets_dir() / "curvy_empty.rou.xml",), road="curvy", sublane=True,
                        ego=EgoStart(lane="center", pos_m=120.0, speed_mps=0.0, lateral_offset_m=1.7),
                        show_ego_outline=show_outline)
    with SumoWorld(config) as world:
        bridge = world.bridge
        bridge.add_route("r", ["curvy"])
        bridge.add_vehicle("car", "r", "car", lane_index=2, pos_m=60.0, speed_mps=15.0)
        bridge.configure_vehicle("car", max_speed_mps=15.0, speed_factor=1.0, imperfection=0.0)
        closest, passed, shown = math.inf, False, set()
        for _ in range(200):
            observation = world.advance(0.0, 0.0, 1.0)
            car = observation.vehicle("car")
            alongside = car is not None and abs(car.road_s_m - observation.ego.road_s_m) < 0.5 * (
                car.length_m + observation.ego.length_m)
            shown.add((alongside, "ego.outline" in bridge._outlines))
            if car is not None:
                closest = min(closest, -1.0 if boxes_overlap(observation.ego, car) else footprint_gap_m(
                    observation.ego, car))
                passed = car.road_s_m > observation.ego.road_s_m + 0.5 * (car.length_m + observation.ego.length_m)
            assert all(v.id != "ego.outline" for v in observation.traffic)  # SUMO's view only, not the ego's
    # Shown while the car comes up (with the outline on), never while it is alongside (SUMO's sublane model would
    # take it for the car's leader at a negative gap).
    assert (False, show_outline) in shown and (True, True) not in shown
    return closest, passed


def test_a_car_in_the_next_lane_goes_round_the_part_of_the_ego_that_sticks_into_it(report):
    closest_shown, passed_shown = passing_car(show_outline=True)
    closest_unseen, passed_unseen = passing_car(show_outline=False)
    report(f"car passing an ego 0.95 m into its lane: closest {closest_unseen:+.2f} m unseen (-1: overlapping),"
           f" {closest_shown:+.2f} m shown; got past: {passed_unseen}, {passed_shown}")
    assert closest_unseen == -1.0 and passed_unseen  # drove straight through the ego's corner
    assert closest_shown > 0.0 and passed_shown  # round it (SUMO's lane-change model, sublane)
