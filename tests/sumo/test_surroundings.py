"""Observation -> Surroundings: disc covers, constant-speed prediction against SUMO, edges and corridors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from agentic_mpc.controller import MPPIConfig
from agentic_mpc.sumo.config import EgoStart, SumoConfig, SurroundingsConfig, VehicleSpawn
from agentic_mpc.sumo.scenarios import net_files
from agentic_mpc.sumo.surroundings import SurroundingsBuilder
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.tactics.config import ALL_RULES, MergeAheadOfQueue, TacticsConfig
from agentic_mpc.tactics.covers import disc_cover
from agentic_mpc.tactics.detour import Detour
from agentic_mpc.tactics.layer import TacticsLayer
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


def builder_of(world: SumoWorld, tactics: TacticsConfig = TacticsConfig(), **update: object) -> WithTactics:
    """The surroundings builder the run loop's controller gets (the default MPPI horizon), with ``update`` to its
    surroundings config, and a tactics layer of ``tactics`` that plans each build as the run loop does."""
    builder = SurroundingsBuilder(world.road, world.ego_length_m, world.ego_width_m, MPPIConfig().horizon, world.dt_s,
                                  world.config.surroundings.model_copy(update=update))
    return WithTactics(builder, TacticsLayer(tactics, builder.tactical_road))


@dataclasses.dataclass
class WithTactics:
    """A builder whose :meth:`build` first asks the tactics layer for its plan, as ``RunLoop.step`` does."""

    builder: SurroundingsBuilder
    layer: TacticsLayer

    def build(self, observation, ego_state, target_lane=None, passing_side=None):
        plan = self.layer.plan(observation, target_lane, passing_side)
        return self.builder.build(observation, ego_state, target_lane, plan)

    def queues(self, observation):
        return self.layer.queues(observation)

    def passing_lanes(self, observation, target_lane):
        return self.layer.plan(observation, target_lane).passing_lanes

    def __getattr__(self, name):
        found = getattr(self.builder, name)
        if name not in ("discs", "leaders", "corridor"):
            return found

        def planned(observation, target_lane=None):  # what the plan opens (passing lanes, queue room) counts
            self.builder._plan = self.layer.plan(observation, target_lane)
            return found(observation, target_lane)

        return planned


WITHOUT_DETOURS = TacticsConfig(rules=("queue_room", "passing_lanes", "gap_acceptance"))
WITHOUT_MERGE_AHEAD = TacticsConfig(rules=tuple(rule for rule in ALL_RULES if rule != "merge_ahead_of_queue"))


def detour(within_m: float | None = 80.0) -> Detour:
    """The detour rules with ``merge_ahead_of_queue`` at ``within_m`` (None: without it)."""
    if within_m is None:
        return Detour(WITHOUT_MERGE_AHEAD)
    return Detour(TacticsConfig(merge_ahead_of_queue=MergeAheadOfQueue(within_m=within_m)))


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
    leader = VehicleSpawn(id="leader", lane="center", pos_m=240.0, speed_mps=10.0, max_speed_mps=10.0)
    extended = SurroundingsConfig(leader_standstill_gap_m=2.0)
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
        # The extension reaches 2 m behind the plain cover when there is room (15 m gap here);
        # centres[0] is the prediction one step ahead, when the leader has moved on by 10 m/s * 0.04 s.
        leader_obs = observation.vehicle("leader")
        reach_back = np.hypot(first[:, 0] - leader_obs.x_m, first[:, 1] - leader_obs.y_m).max()
        assert reach_back == pytest.approx(abs(plain[0]) + 2.0 - 0.4, abs=0.02)


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
    from agentic_mpc.tactics.queues import QUEUE_LEADER_WITHIN_M

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
        off = builder_of(world, WITHOUT_DETOURS)
        assert off.build(observation, world.ego_state, target_lane=1).reference_shift_m == 0.0
    with SumoWorld(beside.replace(ego=EgoStart(lane="center", pos_m=220.0, speed_mps=15.0))) as world:
        assert builder_of(world).build(world.observation, world.ego_state, target_lane=1).reference_shift_m == \
            pytest.approx(-3.5, abs=0.01)
        assert builder_of(world).build(world.observation, world.ego_state, 1, "left").reference_shift_m == \
            pytest.approx(3.5, abs=0.01)
        in_line = builder_of(world, WITHOUT_MERGE_AHEAD)
        assert in_line.build(world.observation, world.ego_state, target_lane=1).reference_shift_m == 0.0


def test_in_the_lane_beside_a_lone_stopped_car_well_ahead_j1_follows_that_lane():
    """The ego in the right lane (as after a yield), a lone stopped car 55 m ahead in the centre lane J1 tracks:
    J1 follows the right lane until the car is behind. Within 20 m of it, where J2's swerve round it takes the
    ego's centre over the line (as in the paper), J1 stays on the tracked lane, unless the ego stands there (as
    after a yield beside the stopped car)."""
    from agentic_mpc.sumo.config import StaticObstacle
    BESIDE_LONE_OBSTACLE_FROM_M = TacticsConfig().pass_beside_queue.lone_obstacle_from_m

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

    config = curvy_config(obstacles=(StaticObstacle(id="stopped", lane="center", pos_m=280.0),),
                          ego=EgoStart(lane="center", pos_m=220.0, speed_mps=10.0),
                          surroundings=SurroundingsConfig(edges="corridor"))
    with SumoWorld(config) as world:
        observation, centres = world.observation, (-3.5, 0.0, 3.5)
        (lone,) = builder_of(world).queues(observation)
        queue = dataclasses.replace(lone, members=("queued",))
        assert 50.0 < queue.tail_gap_m < 60.0

        def lane(rules: Detour, side: str | None = None, seen=observation, queues=(queue,)) -> int | None:
            return rules.lane(seen, queues, 1, centres, side)

        assert lane(detour(80.0), "left") == 2 and lane(detour(80.0), "right") == 0 and lane(detour(80.0)) == 0
        started = detour(80.0)
        assert lane(started, "left") == 2
        crossing = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lane_index=2))
        assert lane(started, "left", crossing) == 2 and lane(started, "left") == 2  # it lasts in both lanes
        past = dataclasses.replace(observation, obstacles=tuple(dataclasses.replace(o, relation="behind")
                                                                for o in observation.obstacles))
        assert lane(started, "left", past, queues=()) is None  # a queue of an obstacle behind is none
        assert lane(detour(80.0), "left", queues=(lone,)) is None
        assert lane(detour(50.0), "left") is None
        assert lane(detour(None), "left") is None
        standing = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, speed_mps=0.0))
        assert lane(detour(80.0), "left", standing) is None
        # From the edge lane the only lane beside is taken, whatever the preference.
        at_edge = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lane_index=0))
        edge_queue = dataclasses.replace(queue, lane_index=0)
        assert detour(80.0).lane(at_edge, (edge_queue,), 0, centres, "right") == 1
    # An emergency vehicle within the distance: its rescue corridor passes the queue, the ego stays in line.
    with SumoWorld(config.replace(vehicles=(VehicleSpawn(id="ambulance", type_id="ambulance", lane="center",
                                                         pos_m=180.0, speed_mps=10.0),))) as world:
        observation = world.observation
        (ambulance,) = observation.emergency_vehicles
        assert ambulance.relation == "behind" and ambulance.distance_m < 80.0
        assert detour(80.0).lane(observation, (queue,), 1, centres, "left") is None
        alone = dataclasses.replace(observation, emergency_vehicles=())
        assert detour(80.0).lane(alone, (queue,), 1, centres, "left") == 2


def test_standing_in_line_behind_a_stopped_car_partly_aside_j1_follows_the_lane_on_that_side():
    """The ego stands in the centre lane J1 tracks, 8 m behind a lone stopped car and 0.8 m right of its lane's
    centre: J1 follows the right lane (3.5 m right) and keeps it while the ego crosses into it, until the car is
    behind; 0.8 m left: the left lane. Straight behind, moving, farther back than a queued car stands, behind a
    queue's cars, or the lane on that side missing (the road's edge): J1 stays on the tracked lane."""
    from agentic_mpc.sumo.config import StaticObstacle
    from agentic_mpc.tactics.queues import QUEUE_LINK_M

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
    
        aside = dataclasses.replace(observation, ego=dataclasses.replace(ego, lateral_offset_m=-0.8))
        centres = (-3.5, 0.0, 3.5)
        assert detour(None).lane(aside, (queue,), 1, centres) == 0
        assert detour(None).lane(aside, (dataclasses.replace(queue, members=("queued",)),), 1, centres) is None
    edge = config.replace(obstacles=(StaticObstacle(id="stopped", lane="right", pos_m=230.0),),
                          ego=EgoStart(lane="right", pos_m=217.0, speed_mps=0.0))
    with SumoWorld(edge) as world:
        observation = world.observation
        seen = dataclasses.replace(observation, ego=dataclasses.replace(observation.ego, lateral_offset_m=-0.8))
        assert builder_of(world).build(seen, world.ego_state, target_lane=0).reference_shift_m == 0.0


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
    config, horizon_s = TacticsConfig().gap_acceptance, builder._horizon_s
    seen = observation.vehicle("follower")
    closing = seen.speed_mps - observation.ego.speed_mps
    braking_mps2 = config.follower_yield_mps2 + config.merge_accel_mps2
    needed_m = closing**2 / (2 * braking_mps2) + config.standstill_gap_m
    assert (seen.gap_m >= needed_m) is lets_in
    travelled_m = [float(np.hypot(*(d.centres[-1] - d.centres[0]))) for d in discs]
    predicted_mps = seen.speed_mps - (0.5 * config.follower_yield_mps2 * horizon_s if lets_in else 0.0)
    predicted_m = predicted_mps * (horizon_s - builder._steps[0])  # from stage 1 to stage H
    assert discs and travelled_m == pytest.approx([predicted_m] * len(discs), rel=0.01)


