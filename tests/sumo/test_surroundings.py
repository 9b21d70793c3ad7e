"""Observation -> Surroundings: disc covers, constant-speed prediction against SUMO, edges and corridors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from agentic_mpc.controller import MPPIConfig
from agentic_mpc.sumo.config import EgoStart, SumoConfig, SurroundingsConfig, VehicleSpawn
from agentic_mpc.sumo.covers import disc_cover
from agentic_mpc.sumo.scenarios import net_files
from agentic_mpc.sumo.surroundings import SurroundingsBuilder
from agentic_mpc.sumo.world import SumoWorld
from tests.sumo.conftest import drive, sumo_loop


@pytest.mark.parametrize(("length", "width", "min_half_width"), [(4.5, 1.8, 0.0), (12.0, 2.5, 0.0), (4.5, 1.8, 2.15)])
def test_discs_cover_the_region_the_ego_centre_must_avoid(length, width, min_half_width):
    cover = disc_cover(length, width, 5.2, 2.0, margin_m=0.5, min_half_width_m=min_half_width)
    half_l, half_w = (length + 5.2) / 2, max((width + 2.0) / 2, min_half_width)
    rng = np.random.default_rng(0)
    inside = rng.uniform([-half_l, -half_w], [half_l, half_w], size=(20000, 2))
    corners = np.array([[sx * half_l, sy * half_w] for sx in (-1, 1) for sy in (-1, 1)])
    centres = np.array([[o, 0.0] for o in cover.offsets_m])

    def covered(points: np.ndarray) -> np.ndarray:
        d2 = ((points[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
        return (d2 <= cover.radius_m**2 + 1e-9).any(axis=1)

    assert covered(inside).all() and covered(corners).all()
    assert cover.radius_m == pytest.approx(half_w + 0.5)  # sideways the cover is only margin larger
    assert len(cover.offsets_m) <= 8


NET, ROUTES = net_files("curvy")


def curvy_config(**update: object) -> SumoConfig:
    base = SumoConfig(net_file=NET, route_files=(ROUTES,), road="curvy",
                       ego=EgoStart(lane="center", pos_m=220.0, speed_mps=15.0))
    return base.replace(**update)


def builder_of(world: SumoWorld, **update: object) -> SurroundingsBuilder:
    """The surroundings builder the run loop's controller gets (the default MPPI horizon), with ``update`` to its
    surroundings config."""
    return SurroundingsBuilder(world.road, world.ego_length_m, world.ego_width_m, MPPIConfig().horizon, world.dt_s,
                               world.config.surroundings.model_copy(update=update))


def test_constant_speed_prediction_matches_sumo_on_a_curve():
    """A SUMO car at constant speed on the curve is where the predicted disc centre says, one second later."""
    car = VehicleSpawn(id="steady", lane="left", pos_m=225.0, speed_mps=15.0, max_speed_mps=15.0,
                       imperfection=0.0, lane_changes=False)
    # Route-file traffic starts at the road's start, far behind: only the steady car is near the ego.
    with sumo_loop(curvy_config(vehicles=(car,)), stop_at_goal=False) as loop:
        drive(loop, 2.0)  # let it settle at exactly 15 m/s
        observation = loop.world.observation
        steady = observation.vehicle("steady")
        assert steady.speed_mps == pytest.approx(15.0)
        builder = builder_of(loop.world)
        points, _ = builder.road.lane_tables[steady.lane_index].at(steady.lane_s_m + 15.0 * builder._steps)
        drive(loop, 1.0)  # 25 steps
        later = loop.world.observation.vehicle("steady")
    assert np.hypot(points[24, 0] - later.x_m, points[24, 1] - later.y_m) < 0.05


def test_followers_in_lane_are_left_out_and_neighbours_are_in():
    vehicles = (
        VehicleSpawn(id="follower", lane="center", pos_m=185.0, speed_mps=16.0),
        VehicleSpawn(id="neighbour", lane="right", pos_m=222.0, speed_mps=15.0),
        VehicleSpawn(id="far", lane="left", pos_m=330.0, speed_mps=15.0),
    )
    with SumoWorld(curvy_config(vehicles=vehicles)) as world:
        builder, observation = builder_of(world), world.observation
        relevant = {v.id for v in observation.traffic if builder.relevant(v, observation.ego.speed_mps)}
    assert "neighbour" in relevant
    assert "follower" not in relevant  # keeping its distance is the follower's job
    assert "far" not in relevant  # 110 m ahead at the same speed: out of reach within the 2 s horizon


def test_a_leader_gets_a_following_distance_that_never_covers_the_ego():
    leader = VehicleSpawn(id="leader", lane="center", pos_m=250.0, speed_mps=10.0, max_speed_mps=10.0)
    extended = SurroundingsConfig(leader_time_headway_s=1.0, leader_standstill_gap_m=2.0)  # no longer the default
    with SumoWorld(curvy_config(vehicles=(leader,), surroundings=extended)) as world:
        builder, observation = builder_of(world), world.observation
        ego = observation.ego
        discs = builder.discs(observation, target_lane=1)
        first = np.array([d.centres[0] for d in discs])
        radius = discs[0].radius_m
        distance = np.hypot(first[:, 0] - ego.x_m, first[:, 1] - ego.y_m)
        plain = disc_cover(4.5, 1.8, 5.2, 2.0).offsets_m
        assert len(discs) > len(plain)  # extended backwards
        assert distance.min() > radius  # ... but not over the ego
        # The extension reaches 2 m + 1 s * 15 m/s behind the plain cover when there is room (25 m gap here);
        # centres[0] is the prediction one step ahead, when the leader has moved on by 10 m/s * 0.04 s.
        leader_obs = observation.vehicle("leader")
        reach_back = np.hypot(first[:, 0] - leader_obs.x_m, first[:, 1] - leader_obs.y_m).max()
        assert reach_back == pytest.approx(abs(plain[0]) + 2.0 + 15.0 - 0.4, abs=0.02)


def test_edges_road_and_corridor():
    config = curvy_config(surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        builder, observation = builder_of(world), world.observation
        road = world.road
        # Road edges: half the road width either side of the centre line.
        left, right = builder.edges(observation.ego.road_s_m, 15.0)
        for edge, sign in ((left, 1.0), (right, -1.0)):
            lateral = road.lateral_from_reference(edge.points[:, 0], edge.points[:, 1])
            assert lateral == pytest.approx(np.full(len(lateral), sign * road.width_m / 2), abs=0.02)
        # Corridor: the ego's own lane only, or its lane and the lane J1 is told to drive.
        assert builder.corridor(observation, target_lane=1) == pytest.approx((1.75, -1.75), abs=0.01)
        assert builder.corridor(observation, target_lane=2) == pytest.approx((5.25, -1.75), abs=0.01)  # 2 = left
        assert builder.corridor(observation, target_lane=None) == pytest.approx((5.25, -5.25), abs=0.01)
        surroundings = builder.build(observation, world.ego_state, target_lane=1)
        lateral = road.lateral_from_reference(*surroundings.road_left_edge.points.T)
        assert lateral == pytest.approx(np.full(len(lateral), 1.75), abs=0.02)
        # The world builds the same for the controller when J1 tracks the centre lane (index 1).
        through_world = world.surroundings(MPPIConfig().horizon, world.lane("center")[1])
        assert through_world.road_left_edge.points == pytest.approx(surroundings.road_left_edge.points)


def test_lane_lines_are_the_lines_between_lanes_from_the_ego_on():
    with SumoWorld(curvy_config()) as world:
        builder, observation = builder_of(world), world.observation
        lines = builder.build(observation, world.ego_state, target_lane=1).lane_lines
        assert lines is not None and lines.offsets_m == pytest.approx((-1.75, 1.75), abs=0.01)  # not the road's edges
        assert (lines.ego_half_length_m, lines.ego_half_width_m) == (0.5 * world.ego_length_m, 0.5 * world.ego_width_m)
        # on the road's centre line, every metre from the ego past the way it covers in a horizon at 15 m/s
        assert world.road.lateral_from_reference(*lines.points.T) == pytest.approx(np.zeros(len(lines.points)), abs=0.02)
        assert np.linalg.norm(lines.points[0] - world.ego_state[:2]) < 0.1
        assert np.diff(lines.points, axis=0) == pytest.approx(np.tile(lines.tangents[:1], (len(lines.points) - 1, 1)),
                                                              abs=0.05)
        assert (len(lines.points) - 1) * lines.spacing_m > 15.0 * MPPIConfig().horizon * world.dt_s
        off = SurroundingsBuilder(world.road, world.ego_length_m, world.ego_width_m, MPPIConfig().horizon, world.dt_s,
                                  SurroundingsConfig(lane_lines=False))
        assert off.build(observation, world.ego_state, target_lane=1).lane_lines is None


def test_the_time_gap_leader_is_the_nearest_vehicle_ahead_in_the_path_and_a_car_cutting_in():
    vehicles = (
        VehicleSpawn(id="leader", lane="center", pos_m=260.0, speed_mps=10.0, max_speed_mps=10.0),
        VehicleSpawn(id="neighbour", lane="left", pos_m=240.0, speed_mps=15.0, max_speed_mps=15.0),
    )
    with SumoWorld(curvy_config(vehicles=vehicles)) as world:
        builder, observation = builder_of(world), world.observation
        ego, leader_obs, neighbour = (observation.ego, observation.vehicle("leader"), observation.vehicle("neighbour"))
        (leader,) = builder.leaders(observation, target_lane=1)  # the neighbour keeps to its lane: not a leader
        assert builder.build(observation, world.ego_state, target_lane=1).leaders[0].contact_points == pytest.approx(
            leader.contact_points)
        assert np.hypot(*leader.tangents.T) == pytest.approx(np.ones(len(leader.tangents)))
        # Stage 1: the leader has moved 0.4 m; measured from the ego's centre the gap is the observed one.
        gap_now = leader.tangents[0] @ (leader.contact_points[0] - [ego.x_m, ego.y_m])
        assert gap_now == pytest.approx(leader_obs.gap_m + 10.0 * 0.04, abs=0.1)
        # Predicted along the lane at constant speed: 10 m/s x 2 s further on at the last stage.
        travelled = np.hypot(*(leader.contact_points[-1] - leader.contact_points[0]))
        assert travelled == pytest.approx(10.0 * 0.04 * (builder.horizon - 1), abs=0.1)
        # The neighbour nearer than the leader cuts in: already 1.5 m over towards the centre lane, or heading
        # into it at 1.5 m/s (it reaches the lane within the lookahead). Nearest first.
        lane_heading = math.atan2(*reversed(world.road.lane_tables[neighbour.lane_index].tangent(neighbour.lane_s_m)))
        for cut_in in (dataclasses.replace(neighbour, lateral_offset_m=-1.5),
                       dataclasses.replace(neighbour, heading_rad=lane_heading - math.asin(1.5 / neighbour.speed_mps))):
            others = tuple(cut_in if v.id == "neighbour" else v for v in observation.traffic)
            leaders = builder.leaders(dataclasses.replace(observation, traffic=others), target_lane=1)
            assert len(leaders) == 2
            first_gap = leaders[0].tangents[0] @ (leaders[0].contact_points[0] - [ego.x_m, ego.y_m])
            assert first_gap == pytest.approx(neighbour.gap_m + 15.0 * 0.04, abs=0.3)
        # Tracking the left lane instead: the neighbour is the leader there.
        (left_leader,) = builder.leaders(observation, target_lane=2)
        assert left_leader.tangents[0] @ (left_leader.contact_points[0] - [ego.x_m, ego.y_m]) == pytest.approx(
            neighbour.gap_m + 15.0 * 0.04, abs=0.3)


def test_a_stopped_car_and_the_queue_behind_it_block_the_lane_together():
    """Two cars standing nose to tail behind a stopped car ahead of the ego: one blockage, its tail the last
    car; the queue is not a time-gap leader (that would hold the ego behind it for ever) unless the ego is
    already nose to tail with it; and the lanes beside open to the corridor for going round."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.sumo.queues import QUEUE_LEADER_WITHIN_M

    obstacle = StaticObstacle(id="stopped", lane="center", pos_m=280.0)
    queue = (VehicleSpawn(id="queued1", lane="center", pos_m=273.0, lane_changes=False),
             VehicleSpawn(id="queued2", lane="center", pos_m=266.0, lane_changes=False))
    config = curvy_config(obstacles=(obstacle,), vehicles=queue, surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        builder, observation = builder_of(world), world.observation
        (blockage,) = builder.queues(observation)
        assert blockage.obstacle_id == "stopped" and blockage.members == ("queued1", "queued2")
        tail = observation.vehicle("queued2")
        assert tail.gap_m > QUEUE_LEADER_WITHIN_M
        # The tail disc sits at the back of the last car's cover, on its lane's heading.
        behind_tail = math.hypot(blockage.tail.x_m - tail.x_m, blockage.tail.y_m - tail.y_m)
        assert 0.0 < behind_tail < 0.5 * (tail.length_m + world.ego_length_m)
        assert builder.leaders(observation, target_lane=1) == ()
        # Within 80 m of the blockage: both lanes beside the centre lane join the corridor.
        assert tail.gap_m < 80.0
        assert builder.passing_lanes(observation, target_lane=1) == frozenset({0, 2})
        assert builder.corridor(observation, target_lane=1) == pytest.approx((5.25, -5.25), abs=0.01)
        assert builder.build(observation, world.ego_state, target_lane=1).blockages == (blockage.tail,)
        # The tail standing 1.2 m right of its lane (as in a rescue lane): the disc stays on the lane's centre
        # line (the band "in line" is the lane's) and carries the car's offset (how far aside counts from it).
        assert blockage.tail.lateral_offset_m == pytest.approx(tail.lateral_offset_m, abs=1e-9)
        heading = tail.heading_rad
        aside = dataclasses.replace(tail, lateral_offset_m=tail.lateral_offset_m - 1.2,
                                    x_m=tail.x_m + 1.2 * math.sin(heading), y_m=tail.y_m - 1.2 * math.cos(heading))
        shifted = dataclasses.replace(observation, traffic=tuple(aside if v.id == tail.id else v
                                                                 for v in observation.traffic))
        (moved,) = builder.queues(shifted)
        assert (moved.tail.x_m, moved.tail.y_m) == pytest.approx((blockage.tail.x_m, blockage.tail.y_m), abs=1e-9)
        assert moved.tail.lateral_offset_m == pytest.approx(tail.lateral_offset_m - 1.2, abs=1e-9)


def test_a_leader_driving_up_to_a_queue_gets_room_behind_it_only_in_the_paths_lane():
    """A car creeps up the centre lane to a queue there: as the leader of a path in the centre lane, J0 keeps the
    room to pull out behind it. Seen from the right lane (where the ego passes), the same car aligned to its lane's
    right edge reaches into the path and is a leader there too, but the ego will not queue behind it: d_0 only."""
    from agentic_mpc.sumo.config import StaticObstacle

    obstacle = StaticObstacle(id="stopped", lane="center", pos_m=280.0)
    vehicles = (VehicleSpawn(id="queued1", lane="center", pos_m=273.0, lane_changes=False),
                VehicleSpawn(id="queued2", lane="center", pos_m=266.0, lane_changes=False),
                VehicleSpawn(id="creeper", lane="center", pos_m=240.0, speed_mps=2.0, lane_changes=False))
    config = curvy_config(obstacles=(obstacle,), vehicles=vehicles, surroundings=SurroundingsConfig(edges="corridor"),
                          ego=EgoStart(lane="right", pos_m=232.0, speed_mps=2.0))
    with SumoWorld(config) as world:
        builder, observation = builder_of(world), world.observation
        creeper = observation.vehicle("creeper")
        (leader,) = builder.leaders(observation, target_lane=1)
        assert leader.queue_lateral_m == pytest.approx(builder._cover(creeper).radius_m)
        heading = creeper.heading_rad
        edge = dataclasses.replace(creeper, lateral_offset_m=creeper.lateral_offset_m - 1.0,
                                   x_m=creeper.x_m + 1.0 * math.sin(heading), y_m=creeper.y_m - 1.0 * math.cos(heading))
        aligned = dataclasses.replace(observation, traffic=tuple(edge if v.id == "creeper" else v
                                                                 for v in observation.traffic))
        (beside,) = builder.leaders(aligned, target_lane=0)
        assert beside.queue_lateral_m is None


def test_beside_a_queue_in_the_tracked_lane_j1_follows_the_lane_the_ego_passes_in():
    """The ego in the right lane, a queue (a stopped car and two behind it) ahead in the centre lane that J1
    tracks: J1's reference moves to the right lane's centre (3.5 m right), until the stopped car is behind the
    ego; switched off, it stays on the tracked lane. With the ego driving in the centre lane towards the queue it
    moves there too (the detour ahead of queues; right, J3 not given), unless that is switched off; with J3 on the
    left, to the left lane."""
    from agentic_mpc.sumo.config import StaticObstacle

    obstacle = StaticObstacle(id="stopped", lane="center", pos_m=280.0)
    queue = (VehicleSpawn(id="queued1", lane="center", pos_m=273.0, lane_changes=False),
             VehicleSpawn(id="queued2", lane="center", pos_m=266.0, lane_changes=False))
    beside = curvy_config(obstacles=(obstacle,), vehicles=queue,
                          ego=EgoStart(lane="right", pos_m=220.0, speed_mps=15.0),
                          surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(beside) as world:
        builder, observation = builder_of(world), world.observation
        assert observation.ego.lane_index == 0 and builder.queues(observation)[0].members == ("queued1", "queued2")
        surroundings = builder.build(observation, world.ego_state, target_lane=1)
        assert surroundings.reference_shift_m == pytest.approx(-3.5, abs=0.01)  # the lanes measured mid-road
        # The corridor is the right lane's (the queue's lane is not one to pull into beside it).
        assert builder.corridor(observation, target_lane=0) == pytest.approx((-1.75, -5.25), abs=0.01)
        # Past the stopped car (seen as behind the ego), the detour ends.
        past = dataclasses.replace(observation, obstacles=tuple(dataclasses.replace(o, relation="behind")
                                                                for o in observation.obstacles))
        assert builder.build(past, world.ego_state, target_lane=1).reference_shift_m == 0.0
        off = SurroundingsBuilder(world.road, world.ego_length_m, world.ego_width_m, MPPIConfig().horizon, world.dt_s,
                                  SurroundingsConfig(edges="corridor", detour_beside_queues=False))
        assert off.build(observation, world.ego_state, target_lane=1).reference_shift_m == 0.0
    with SumoWorld(beside.replace(ego=EgoStart(lane="center", pos_m=220.0, speed_mps=15.0))) as world:
        assert builder_of(world).build(world.observation, world.ego_state, target_lane=1).reference_shift_m == \
            pytest.approx(-3.5, abs=0.01)
        assert builder_of(world).build(world.observation, world.ego_state, 1, "left").reference_shift_m == \
            pytest.approx(3.5, abs=0.01)
        in_line = builder_of(world, detour_ahead_of_queues_m=None)
        assert in_line.build(world.observation, world.ego_state, target_lane=1).reference_shift_m == 0.0


def test_in_the_lane_beside_a_lone_stopped_car_well_ahead_j1_follows_that_lane():
    """The ego in the right lane (as after a yield), a lone stopped car 55 m ahead in the centre lane J1 tracks:
    J1 follows the right lane until the car is behind. Within 20 m of it, where J2's swerve round it takes the
    ego's centre over the line (as in the paper), J1 stays on the tracked lane, unless the ego stands there (as
    after a yield beside the stopped car)."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.sumo.queues import BESIDE_LONE_OBSTACLE_FROM_M

    config = curvy_config(obstacles=(StaticObstacle(id="stopped", lane="center", pos_m=280.0),),
                          ego=EgoStart(lane="right", pos_m=220.0, speed_mps=2.0),
                          surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        builder, observation = builder_of(world), world.observation
        (queue,) = builder.queues(observation)
        assert queue.members == () and queue.tail_gap_m == pytest.approx(55.0, abs=1.0)
        assert builder.build(observation, world.ego_state, target_lane=1).reference_shift_m == pytest.approx(
            -3.5, abs=0.01)
        past = dataclasses.replace(observation, obstacles=tuple(dataclasses.replace(o, relation="behind")
                                                                for o in observation.obstacles))
        assert builder.build(past, world.ego_state, target_lane=1).reference_shift_m == 0.0
        near = dataclasses.replace(observation, obstacles=tuple(
            dataclasses.replace(o, gap_m=BESIDE_LONE_OBSTACLE_FROM_M - 1.0) for o in observation.obstacles))
        assert builder_of(world).build(near, world.ego_state, target_lane=1).reference_shift_m == 0.0
        standing = dataclasses.replace(near, ego=dataclasses.replace(near.ego, speed_mps=0.5))
        assert builder_of(world).build(standing, world.ego_state, target_lane=1).reference_shift_m == pytest.approx(
            -3.5, abs=0.01)


def test_driving_towards_a_queue_j1_follows_the_lane_beside_on_the_preferred_side():
    """``detour_ahead_of_queues_m``: the ego drives in the centre lane J1 tracks towards a stopped car with a car
    queued behind it, 55 m ahead: J1 follows the lane beside on J3's side (right without a preference) until the
    car is behind, also while the ego is still in the centre lane. Not towards a lone stopped car (J2's, as in
    the paper), farther than the distance, standing (the in-line start's), with an emergency vehicle within the
    distance, or with the switch off."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.sumo.queues import Detour

    config = curvy_config(obstacles=(StaticObstacle(id="stopped", lane="center", pos_m=280.0),),
                          ego=EgoStart(lane="center", pos_m=220.0, speed_mps=10.0),
                          surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        observation, centres = world.observation, (-3.5, 0.0, 3.5)
        (lone,) = builder_of(world).queues(observation)
        queue = dataclasses.replace(lone, members=("queued",))
        assert 50.0 < queue.tail_gap_m < 60.0

        def lane(detour: Detour, side: str | None = None, seen=observation, queues=(queue,)) -> int | None:
            return detour.lane(seen, queues, 1, 80.0, centres, side)

        assert lane(Detour(80.0), "left") == 2 and lane(Detour(80.0), "right") == 0 and lane(Detour(80.0)) == 0
        detour = Detour(80.0)
        assert lane(detour, "left") == 2
        crossing = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lane_index=2))
        assert lane(detour, "left", crossing) == 2 and lane(detour, "left") == 2  # it lasts in both lanes
        past = dataclasses.replace(observation, obstacles=tuple(dataclasses.replace(o, relation="behind")
                                                                for o in observation.obstacles))
        assert lane(detour, "left", past, queues=()) is None  # a queue of an obstacle behind is none
        assert lane(Detour(80.0), "left", queues=(lone,)) is None
        assert lane(Detour(50.0), "left") is None
        assert lane(Detour(None), "left") is None
        standing = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, speed_mps=0.0))
        assert lane(Detour(80.0), "left", standing) is None
        # From the edge lane the only lane beside is taken, whatever the preference.
        at_edge = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lane_index=0))
        edge_queue = dataclasses.replace(queue, lane_index=0)
        assert Detour(80.0).lane(at_edge, (edge_queue,), 0, 80.0, centres, "right") == 1
    # An emergency vehicle within the distance: its rescue corridor passes the queue, the ego stays in line.
    with SumoWorld(config.replace(vehicles=(VehicleSpawn(id="ambulance", type_id="ambulance", lane="center",
                                                         pos_m=180.0, speed_mps=10.0),))) as world:
        observation = world.observation
        (ambulance,) = observation.emergency_vehicles
        assert ambulance.relation == "behind" and ambulance.distance_m < 80.0
        assert Detour(80.0).lane(observation, (queue,), 1, 80.0, centres, "left") is None
        alone = dataclasses.replace(observation, emergency_vehicles=())
        assert Detour(80.0).lane(alone, (queue,), 1, 80.0, centres, "left") == 2


def test_standing_in_line_behind_a_stopped_car_partly_aside_j1_follows_the_lane_on_that_side():
    """The ego stands in the centre lane J1 tracks, 8 m behind a lone stopped car and 0.8 m right of its lane's
    centre: J1 follows the right lane (3.5 m right) and keeps it while the ego crosses into it, until the car is
    behind; 0.8 m left: the left lane. Straight behind, moving, farther back than a queued car stands, behind a
    queue's cars, or the lane on that side missing (the road's edge): J1 stays on the tracked lane."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.sumo.queues import QUEUE_LINK_M

    config = curvy_config(obstacles=(StaticObstacle(id="stopped", lane="center", pos_m=230.0),),
                          ego=EgoStart(lane="center", pos_m=217.0, speed_mps=0.0),
                          surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        observation = world.observation
        ego, (queue,) = observation.ego, builder_of(world).queues(observation)
        assert queue.members == () and 0.0 < queue.tail_gap_m <= QUEUE_LINK_M and ego.lane_index == 1

        def shift(builder: SurroundingsBuilder, target_lane: int = 1, **ego_update: object) -> float:
            seen = dataclasses.replace(observation, ego=dataclasses.replace(ego, **ego_update))
            return builder.build(seen, world.ego_state, target_lane=target_lane).reference_shift_m

        builder = builder_of(world)
        assert shift(builder, lateral_offset_m=-0.8) == pytest.approx(-3.5, abs=0.01)
        # It lasts while the ego crosses into the right lane, and ends once the stopped car is behind it.
        assert shift(builder, lateral_offset_m=1.5, lane_index=0, speed_mps=3.0) == pytest.approx(-3.5, abs=0.01)
        past = dataclasses.replace(observation, obstacles=tuple(dataclasses.replace(o, relation="behind")
                                                                for o in observation.obstacles))
        assert builder.build(past, world.ego_state, target_lane=1).reference_shift_m == 0.0
        assert shift(builder_of(world), lateral_offset_m=0.8) == pytest.approx(3.5, abs=0.01)
        assert shift(builder_of(world), lateral_offset_m=-0.1) == 0.0  # straight behind: J2's, as in the paper
        assert shift(builder_of(world), lateral_offset_m=-0.8, speed_mps=3.0) == 0.0
        far = dataclasses.replace(observation, obstacles=tuple(dataclasses.replace(o, gap_m=QUEUE_LINK_M + 1.0)
                                                               for o in observation.obstacles))
        far = dataclasses.replace(far, ego=dataclasses.replace(ego, lateral_offset_m=-0.8))
        assert builder_of(world).build(far, world.ego_state, target_lane=1).reference_shift_m == 0.0
        # Behind a queue's cars it is the zipper's merge (J0's gap acceptance), not a detour.
        from agentic_mpc.sumo.queues import Detour

        aside = dataclasses.replace(observation, ego=dataclasses.replace(ego, lateral_offset_m=-0.8))
        centres = (-3.5, 0.0, 3.5)
        assert Detour().lane(aside, (queue,), 1, 80.0, centres) == 0
        assert Detour().lane(aside, (dataclasses.replace(queue, members=("queued",)),), 1, 80.0, centres) is None
    edge = config.replace(obstacles=(StaticObstacle(id="stopped", lane="right", pos_m=230.0),),
                          ego=EgoStart(lane="right", pos_m=217.0, speed_mps=0.0))
    with SumoWorld(edge) as world:
        observation = world.observation
        seen = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lateral_offset_m=-0.8))
        assert builder_of(world).build(seen, world.ego_state, target_lane=0).reference_shift_m == 0.0


def test_coming_up_to_a_queue_j1_slows_to_a_speed_it_can_stop_from_with_room():
    """A queue (a stopped car, two behind it) ahead in the ego's lane: J1's reference speed is capped at the
    speed from which braking at approach_decel_mps2 stops the ego the model's pull-out room behind the last car
    (at least 2 m/s), whichever lane J1 follows; a lone stopped car (the paper's Scenario 1), the ego in the lane
    beside, or the cap off (the default): no cap."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.vehicle import PAPER_PARAMS

    obstacle = StaticObstacle(id="stopped", lane="center", pos_m=295.0)
    queue = (VehicleSpawn(id="queued1", lane="center", pos_m=288.0, lane_changes=False),
             VehicleSpawn(id="queued2", lane="center", pos_m=281.0, lane_changes=False))
    on = SurroundingsConfig(edges="corridor", approach_decel_mps2=2.0)
    config = curvy_config(obstacles=(obstacle,), vehicles=queue, surroundings=on)
    with SumoWorld(config) as world:
        builder, observation = builder_of(world), world.observation
        (blockage,) = builder.queues(observation)
        room = PAPER_PARAMS.pull_out_distance_m(blockage.tail.radius_m)
        assert 5.0 < room < 7.0 and blockage.tail_gap_m > room + 20.0
        cap = builder.build(observation, world.ego_state, target_lane=1).reference_speed_cap_mps
        assert cap == pytest.approx(math.sqrt(2.0 * 2.0 * (blockage.tail_gap_m - room)), rel=1e-12)
        assert cap < 15.0
        # J1 on the lane beside (a detour) while the ego is still in the queue's lane: the same cap
        assert builder.build(observation, world.ego_state, target_lane=2).reference_speed_cap_mps == cap
        nearly_there = dataclasses.replace(blockage, tail_gap_m=room + 0.3)
        from agentic_mpc.sumo.queues import approach_speed_cap_mps

        assert approach_speed_cap_mps((nearly_there,), 1, 2.0, PAPER_PARAMS.pull_out_distance_m) == 2.0
        assert approach_speed_cap_mps((nearly_there,), 0, 2.0, PAPER_PARAMS.pull_out_distance_m) is None
        alone = dataclasses.replace(blockage, members=())
        assert approach_speed_cap_mps((alone,), 1, 2.0, PAPER_PARAMS.pull_out_distance_m) is None
        off = SurroundingsBuilder(world.road, world.ego_length_m, world.ego_width_m, MPPIConfig().horizon, world.dt_s,
                                  SurroundingsConfig(edges="corridor"))  # the default: off
        assert off.build(observation, world.ego_state, target_lane=1).reference_speed_cap_mps is None
    with SumoWorld(config.replace(ego=EgoStart(lane="right", pos_m=220.0, speed_mps=15.0))) as world:
        surroundings = builder_of(world).build(world.observation, world.ego_state, target_lane=1)
        assert surroundings.reference_speed_cap_mps is None  # passing it in the lane beside (the detour's)


def test_driving_towards_a_queue_the_merge_can_wait_for_room_in_the_lane_beside_and_slow_meanwhile():
    """``detour_merge_waits_from_mps`` (off by default): the detour towards a queue takes the lane beside only with
    room in it. With a car alongside there, J1 keeps the ego's lane and its reference slows to stop with room behind
    the queue (braking at 2 m/s²); with the car far behind, J1 follows the lane beside and nothing is capped. A follower closer than 2 m + 0.5 s of its speed + its
    braking distance (2 m/s²) down to the ego's speed, or a car ahead within 2 m, leaves no room either. Once the
    ego's centre is in the lane beside, the merge goes on whatever is there; slower than the option's 8 m/s it does not
    wait (J0's gap acceptance decides the zipper), nor with the option off."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.sumo.queues import MERGE_WAIT_DECEL_MPS2, Detour, room_to_merge
    from agentic_mpc.vehicle import PAPER_PARAMS

    queue = (VehicleSpawn(id="queued1", lane="center", pos_m=288.0, lane_changes=False),
             VehicleSpawn(id="queued2", lane="center", pos_m=281.0, lane_changes=False))
    beside = VehicleSpawn(id="beside", lane="right", pos_m=220.0, speed_mps=15.0, lane_changes=False)
    config = curvy_config(obstacles=(StaticObstacle(id="stopped", lane="center", pos_m=295.0),),
                          vehicles=(*queue, beside), surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        observation = world.observation
        (car,) = [v for v in observation.traffic if v.id == "beside"]
        assert car.relation == "alongside" and car.lane_index == 0
        builder = builder_of(world, detour_merge_waits_from_mps=8.0)
        (blockage,) = builder.queues(observation)
        assert blockage.members and 30.0 < blockage.tail_gap_m < 80.0
        off = builder_of(world).build(observation, world.ego_state, target_lane=1, passing_side="right")
        assert off.reference_shift_m == pytest.approx(-3.5, abs=0.01) and off.reference_speed_cap_mps is None
        waiting = builder.build(observation, world.ego_state, target_lane=1, passing_side="right")
        room = PAPER_PARAMS.pull_out_distance_m(blockage.tail.radius_m)
        assert waiting.reference_shift_m == 0.0
        assert waiting.reference_speed_cap_mps == pytest.approx(
            math.sqrt(2.0 * MERGE_WAIT_DECEL_MPS2 * (blockage.tail_gap_m - room)), rel=1e-12)
        assert waiting.reference_speed_cap_mps < 15.0

        def with_car(**update: object):
            traffic = tuple(dataclasses.replace(v, **update) if v.id == "beside" else v for v in observation.traffic)
            return dataclasses.replace(observation, traffic=traffic)

        far_behind = with_car(relation="behind", gap_m=40.0)
        merging = builder.build(far_behind, world.ego_state, target_lane=1, passing_side="right")
        assert merging.reference_shift_m == pytest.approx(-3.5, abs=0.01) and merging.reference_speed_cap_mps is None
        # a follower at 15 m/s, the ego at 15 m/s: 2 + 7.5 m; at 20 m/s: 2 + 10 + 6.25 m
        assert room_to_merge(with_car(relation="behind", gap_m=9.6), 0)
        assert not room_to_merge(with_car(relation="behind", gap_m=9.4), 0)
        assert not room_to_merge(with_car(relation="behind", gap_m=18.0, speed_mps=20.0), 0)
        assert room_to_merge(with_car(relation="behind", gap_m=18.4, speed_mps=20.0), 0)
        assert not room_to_merge(with_car(relation="ahead", gap_m=1.5), 0)
        assert room_to_merge(with_car(relation="ahead", gap_m=2.5), 0)
        assert not room_to_merge(observation, 0) and room_to_merge(observation, 2)
        detour, centres = Detour(80.0, merge_waits_from_mps=8.0), (-3.5, 0.0, 3.5)
        assert detour.lane(observation, (blockage,), 1, 80.0, centres, "right") is None
        assert detour.waiting_decel_mps2 == MERGE_WAIT_DECEL_MPS2
        crossed = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lane_index=0))
        assert detour.lane(far_behind, (blockage,), 1, 80.0, centres, "right") == 0
        assert detour.lane(crossed, (blockage,), 1, 80.0, centres, "right") == 0
        assert detour.waiting_decel_mps2 is None
        slow = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, speed_mps=7.9))
        assert Detour(80.0, merge_waits_from_mps=8.0).lane(slow, (blockage,), 1, 80.0, centres, "right") == 0
        assert Detour(80.0).lane(observation, (blockage,), 1, 80.0, centres, "right") == 0  # off


def test_a_vehicle_from_behind_in_a_lane_beside_is_a_follower_charged_only_for_coming_closer():
    vehicles = (
        VehicleSpawn(id="behind_left", lane="left", pos_m=214.0, speed_mps=17.0),
        VehicleSpawn(id="ahead_right", lane="right", pos_m=226.0, speed_mps=15.0),
    )
    with SumoWorld(curvy_config(vehicles=vehicles)) as world:
        observation = world.observation
        behind, ahead = observation.vehicle("behind_left"), observation.vehicle("ahead_right")
        assert behind.offset_m < 0.0 < ahead.offset_m
        builder = builder_of(world, followers_charge_approach=True)
        discs = builder.discs(observation)
        plain = builder_of(world).discs(observation)  # off by default
        ego = observation.ego
        ego_lateral = builder._lane_centres[ego.lane_index] + ego.lateral_offset_m
    gap_left = builder._lane_centres[behind.lane_index] + behind.lateral_offset_m - ego_lateral
    assert gap_left > 2.5
    followers = [d for d in discs if d.follower_side != 0.0]
    assert followers and {d.follower_side for d in followers} == {1.0}  # on the left
    assert all(d.follower_gap_now_m == pytest.approx(gap_left, abs=0.01) for d in followers)
    assert len(followers) < len(discs)  # the one ahead on the right is charged as before
    assert len(plain) == len(discs) and {d.follower_side for d in plain} == {0.0}


@pytest.mark.parametrize(("follower_pos_m", "lets_in"), [(212.0, False), (195.0, True)])
def test_a_follower_beside_a_blockage_is_predicted_to_let_the_ego_in_only_where_it_can(follower_pos_m, lets_in):
    """Standing behind a stopped car, the ego may pull out into the left lane. A follower there far enough back to let
    it in (braking at follower_yield_mps2 while the ego speeds up) is predicted braking; one 15 m back at 14 m/s (seed
    3612: the ego pulled out in front of it and side-swiped it) keeps its speed, so pulling out in front of it pays."""
    from agentic_mpc.sumo.config import StaticObstacle

    obstacle = StaticObstacle(id="stopped", lane="center", pos_m=245.0)
    follower = VehicleSpawn(id="follower", lane="left", pos_m=follower_pos_m, speed_mps=14.0, max_speed_mps=14.0,
                            imperfection=0.0, lane_changes=False)
    config = curvy_config(obstacles=(obstacle,), vehicles=(follower,), ego=EgoStart(lane="center", pos_m=233.0,
                          speed_mps=0.0), surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        builder, observation = builder_of(world), world.observation
        assert 2 in builder.passing_lanes(observation, target_lane=1)
        discs = builder.discs(observation, target_lane=1)
    config, horizon_s = builder.config, builder._horizon_s
    seen = observation.vehicle("follower")
    closing = seen.speed_mps - observation.ego.speed_mps
    braking_mps2 = config.follower_yield_mps2 + config.follower_yield_merge_accel_mps2
    needed_m = closing**2 / (2 * braking_mps2) + config.leader_standstill_gap_m
    assert (seen.gap_m >= needed_m) is lets_in
    travelled_m = [float(np.hypot(*(d.centres[-1] - d.centres[0]))) for d in discs]
    predicted_mps = seen.speed_mps - (0.5 * config.follower_yield_mps2 * horizon_s if lets_in else 0.0)
    predicted_m = predicted_mps * (horizon_s - builder._steps[0])  # from stage 1 to stage H
    assert discs and travelled_m == pytest.approx([predicted_m] * len(discs), rel=0.01)


def test_lane_neighbours_are_the_nearest_behind_and_ahead_in_the_lane_the_ego_may_enter():
    vehicles = (
        VehicleSpawn(id="left_behind", lane="left", pos_m=207.0, speed_mps=15.5),
        VehicleSpawn(id="right_behind", lane="right", pos_m=200.0, speed_mps=16.5),
        VehicleSpawn(id="right_ahead", lane="right", pos_m=228.0, speed_mps=15.5),
        VehicleSpawn(id="same_lane_ahead", lane="center", pos_m=240.0, speed_mps=14.0),
    )
    with SumoWorld(curvy_config(vehicles=vehicles)) as world:
        observation = world.observation
        builder = builder_of(world, lane_neighbours=True)
        assert builder_of(world).build(observation, world.ego_state, target_lane=0).lane_neighbours == ()  # off
        expected = {v.id: v for v in observation.traffic}
        assert set(expected) == {v.id for v in vehicles}
        lane_of = {name: expected[name].lane_index for name in expected}
        # J1 on the lane to the left: only its car; on the lane to the right: both of its; on its own lane: none
        to_left = builder.build(observation, world.ego_state, target_lane=lane_of["left_behind"]).lane_neighbours
        to_right = builder.build(observation, world.ego_state, target_lane=lane_of["right_ahead"]).lane_neighbours
        holding = builder.build(observation, world.ego_state, target_lane=observation.ego.lane_index).lane_neighbours
        ego = observation.ego
        lane_centre = {i: 0.5 * (left + right) for i, (left, right) in enumerate(world.road.lane_bounds_m)}
        ego_lateral = lane_centre[ego.lane_index] + ego.lateral_offset_m
    assert (len(to_left), len(to_right), len(holding)) == (1, 2, 0)
    for name, neighbours in (("left_behind", to_left), ("right_behind", to_right), ("right_ahead", to_right)):
        vehicle = expected[name]
        neighbour = min(neighbours, key=lambda n: float(np.hypot(*(n.centres[0] - (vehicle.x_m, vehicle.y_m)))))
        assert np.hypot(*(neighbour.centres[0] - (vehicle.x_m, vehicle.y_m))) < vehicle.speed_mps * 0.04 + 0.1
        assert neighbour.speed_mps == pytest.approx(vehicle.speed_mps)
        assert neighbour.contact_m == pytest.approx(0.5 * (vehicle.length_m + world.ego_length_m))
        lane_width = world.road.lane_widths_m[vehicle.lane_index]
        assert neighbour.lane_reach_m == pytest.approx(0.5 * (lane_width + world.ego_width_m))
        # how far the ego's body is in that lane now: outside, by its distance to the lane's centre less the reach
        distance = abs(lane_centre[vehicle.lane_index] - ego_lateral)
        assert neighbour.entry_depth_now_m == pytest.approx(neighbour.lane_reach_m - distance, abs=0.02)
        assert neighbour.entry_depth_now_m < 0.0
