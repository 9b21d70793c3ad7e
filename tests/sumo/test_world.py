"""The SUMO world under the run loop against real SUMO: the controller drives the ego, SUMO the traffic."""

from __future__ import annotations

import math
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import pytest

from agentic_mpc.primitives import ObstacleAvoidance, PathTracking
from agentic_mpc.run.loop import LoopSettings, RunLoop
from agentic_mpc.sumo import bridge
from agentic_mpc.sumo.config import EgoStart, StaticObstacle, SumoConfig, VehicleSpawn
from agentic_mpc.sumo.scenarios import curvy_traffic_config, net_files, scenario1_config
from agentic_mpc.sumo.world import SumoWorld
from agentic_mpc.world.base import WorldError
from tests.sumo.conftest import default_specification, drive, position_error_m, sumo_loop

STRAIGHT_NET, STRAIGHT_ROUTES = net_files("straight")


def straight_config(**update: object) -> SumoConfig:
    base = SumoConfig(net_file=STRAIGHT_NET, route_files=(STRAIGHT_ROUTES,), road="straight",
                       ego=EgoStart(lane="center", pos_m=100.0, speed_mps=15.0))
    return base.replace(**update)


def drive_curvy_lane(seed: int, lane: str = "center", lefthand: bool = False) -> dict:
    """Drive one lane of the curved road start to goal in traffic; returns what was measured."""
    counts = []
    with sumo_loop(curvy_traffic_config(lane=lane, lefthand=lefthand), seed=seed) as loop:
        world = loop.world
        expected_index = world.road.lane_index(lane)

        def count(loop: RunLoop, outcome) -> None:
            if len(loop.recorder.trajectory_rows) % 25 == 1:
                counts.append(world.bridge.vehicle_count() - 1)

        collisions = drive(loop, 200.0, on_step=count)
        records = loop.recorder.trajectory_rows
        summary = {"steps": len(records), "time_s": world.time_s,
                   "reached_goal": world.observation.ego.road_s_m >= world.goal_s_m}
    xy_sumo = np.array([(r["sumo_x_m"], r["sumo_y_m"]) for r in records])
    v_model = np.array([r["v_mps"] for r in records])
    # Independent of the speed we write into SUMO: how far SUMO saw the ego move in each step.
    displacement_speed = np.hypot(*np.diff(xy_sumo, axis=0).T) / 0.04
    return {
        "summary": summary,
        "collisions": collisions,
        "min_vehicles": min(counts),
        "lanes": {r["lane_index"] for r in records},
        "expected_lane": expected_index,
        "max_position_error_m": max(position_error_m(r) for r in records),
        "max_speed_error_mps": max(abs(r["sumo_speed_mps"] - r["v_mps"]) for r in records),
        "max_displacement_speed_error_mps": float(np.abs(displacement_speed - v_model[:-1]).max()),
        "max_lateral_m": max(abs(r["lateral_offset_m"]) for r in records),
        "mean_speed_mps": float(v_model.mean()),
        "median_step_ms": float(np.median([r["step_ms"] for r in records])),
    }


def check_curvy_drive(result: dict) -> None:
    summary = result["summary"]
    assert summary["reached_goal"]
    assert result["collisions"] == [], result["collisions"][:3]
    assert result["min_vehicles"] >= 20
    assert result["lanes"] == {result["expected_lane"]}  # SUMO had the ego on the given lane throughout
    assert result["max_position_error_m"] < 0.05
    assert result["max_speed_error_mps"] < 1e-6
    # Centre vs front bumper displacement differ only by the yaw rate: a few mm/s.
    assert result["max_displacement_speed_error_mps"] < 0.05


def test_ego_drives_a_lane_of_the_curvy_road_through_traffic(report):
    result = drive_curvy_lane(seed=0)
    s = result["summary"]
    report(
        f"curvy road, seed 0, centre lane: {s['steps']} steps ({s['time_s']:.1f} s sim time),"
        f" reached goal {s['reached_goal']},"
        f" collisions {len(result['collisions'])}, vehicles in SUMO >= {result['min_vehicles']},"
        f" max |position error| {result['max_position_error_m']:.2e} m,"
        f" max |speed error| {result['max_speed_error_mps']:.2e} m/s (displacement-based"
        f" {result['max_displacement_speed_error_mps']:.4f}), max |lateral offset| {result['max_lateral_m']:.2f} m,"
        f" mean speed {result['mean_speed_mps']:.2f} m/s, median step {result['median_step_ms']:.3f} ms"
    )
    check_curvy_drive(result)


@pytest.mark.slow
@pytest.mark.parametrize(("lane", "lefthand", "seeds"), [
    ("center", False, 4),
    # The outer lanes wobbled up to 2.1 m off the lane centre (seeds 0 and 6) while the MPPI average had
    # collapsed; since the controller's averaging was fixed (docs/cost-design.md) they stay within 0.32 m.
    # Few seeds keep the suite's time (tests/sumo/test_ride_comfort.py measures the controller over many).
    ("left", True, 3),
    ("right", False, 3),
])
def test_curvy_road_seeds_without_collision(report, lane, lefthand, seeds):
    # libsumo runs one simulation per process: each seed in a fresh process, two at a time
    context = multiprocessing.get_context("forkserver")
    with ProcessPoolExecutor(max_workers=2, mp_context=context, max_tasks_per_child=1) as pool:
        results = list(pool.map(drive_curvy_lane, range(seeds), [lane] * seeds, [lefthand] * seeds))
    report(
        f"curvy road, {lane} lane, {'left' if lefthand else 'right'}-hand traffic, {seeds} seeds:"
        f" collisions {[len(r['collisions']) for r in results]},"
        f" min vehicles {[r['min_vehicles'] for r in results]},"
        f" max position error {max(r['max_position_error_m'] for r in results):.2e} m,"
        f" max lateral offset {[round(r['max_lateral_m'], 2) for r in results]} m,"
        f" median step {[round(r['median_step_ms'], 3) for r in results]} ms,"
        f" SUMO lanes {[sorted(r['lanes']) for r in results]}"
    )
    for result in results:
        check_curvy_drive(result)
        assert result["max_lateral_m"] < 0.5  # no wobble towards the next lane


def test_follower_brakes_when_the_ego_stops(report):
    follower = VehicleSpawn(id="follower", lane="center", pos_m=65.0, speed_mps=15.0, imperfection=0.0,
                            lane_changes=False)
    with sumo_loop(straight_config(vehicles=(follower,)), stop_at_goal=False) as loop:
        path = loop.world.road.lane_path("center")
        start = loop.world.time_s
        trace = []

        def stop_after_two_seconds(loop: RunLoop, outcome) -> None:
            t = outcome.observation.time_s
            if t >= start + 2.0 and loop.slot.version == 0:
                loop.slot.update(lambda spec: spec.attach(PathTracking(path=path, lane="center", v_ref_mps=0.0)))
            f = loop.world.observation.vehicle("follower")
            trace.append((t - start, float(outcome.state[3]), f.speed_mps, f.gap_m))

        collisions = drive(loop, 14.0, on_step=stop_after_two_seconds)
    t, ego_v, follower_v, gap = (np.array(column) for column in zip(*trace))
    ego_stopped = t[np.argmax(ego_v < 0.05)]
    follower_brakes = t[np.argmax((t > 2.0) & (follower_v < 14.0))]
    report(
        f"ego stops at t={ego_stopped:.2f} s (v_ref=0 from t=2.0 s);"
        f" follower below 14 m/s at t={follower_brakes:.2f} s,"
        f" final speed {follower_v[-1]:.2f} m/s, final gap {gap[-1]:.2f} m, min gap {gap.min():.2f} m"
    )
    assert collisions == []
    assert ego_v[-1] < 0.05
    assert follower_v[-1] < 0.1  # it stopped behind the ego (it may not change lanes)
    assert 2.0 < follower_brakes < ego_stopped  # it reacted while the ego was braking
    assert gap.min() > 0.5


def test_stopped_vehicle_obstacle_is_not_driven_through(report):
    """Cars that may change lanes go around the obstacle; cars that may not stop behind it."""
    obstacle = StaticObstacle(id="obstacle", lane="center", pos_m=250.0, in_j2=False)
    cars = (
        VehicleSpawn(id="stuck0", lane="center", pos_m=165.0, speed_mps=14.0, lane_changes=False),
        VehicleSpawn(id="stuck1", lane="center", pos_m=85.0, speed_mps=14.0, lane_changes=False),
        VehicleSpawn(id="around0", lane="center", pos_m=190.0, speed_mps=14.0),
        VehicleSpawn(id="around1", lane="center", pos_m=125.0, speed_mps=14.0),
    )
    # The ego waits in the right lane far behind (v_ref = 0), out of everybody's way.
    config = straight_config(obstacles=(obstacle,), vehicles=cars, sensing_range_m=600.0,
                             ego=EgoStart(lane="right", pos_m=20.0, speed_mps=0.0))
    with sumo_loop(config, v_ref_mps=0.0, stop_at_goal=False) as loop:
        world = loop.world
        rear = world.observation.obstacles[0].road_s_m - 0.5 * world.observation.obstacles[0].length_m
        passed_through = []
        lanes_passing = {}

        def watch(loop: RunLoop, outcome) -> None:
            for v in world.observation.traffic:
                front = v.road_s_m + 0.5 * v.length_m
                if v.lane_role == "center" and front > rear and v.road_s_m < rear + 10.0:
                    passed_through.append((v.id, round(front - rear, 2)))
                if v.road_s_m > rear + 10.0:
                    lanes_passing.setdefault(v.id, v.lane_role)

        collisions = drive(loop, 30.0, on_step=watch)
        final = {v.id: v for v in world.observation.traffic}
        obstacle_now = world.observation.obstacles[0]
    report(
        f"obstacle rear at s={rear:.1f} m; passed it in lanes {lanes_passing};"
        f" stopped behind: " + ", ".join(f"{i} gap {rear - final[i].road_s_m - 0.5 * final[i].length_m:.2f} m"
                                         f" at {final[i].speed_mps:.2f} m/s" for i in ("stuck0", "stuck1"))
    )
    assert collisions == []
    assert passed_through == []
    assert set(lanes_passing) == {"around0", "around1"} and "center" not in lanes_passing.values()
    for vehicle_id in ("stuck0", "stuck1"):
        assert final[vehicle_id].speed_mps < 0.1
        assert final[vehicle_id].road_s_m < rear
    assert obstacle_now.lane_role == "center" and obstacle_now.road_s_m == pytest.approx(250.0 - 2.25, abs=1e-6)


def test_scenario1_ego_evades_the_obstacle_that_j2_sees(report):
    with sumo_loop(scenario1_config(), seed=3) as loop:
        world = loop.world
        specification = loop.slot.current
        circles = specification.get("obstacle_avoidance")
        assert isinstance(circles, ObstacleAvoidance) and len(circles.obstacles) >= 3
        obstacle = world.observation.obstacles[0]
        assert obstacle.relation == "ahead" and obstacle.relative_lane == 0
        assert obstacle.gap_m == pytest.approx(110.0 - 4.5 - 30.0, abs=0.01)  # front to rear bumper
        min_clearance = math.inf
        passed = False

        def watch(loop: RunLoop, outcome) -> bool:
            nonlocal min_clearance, passed
            o = world.observation.obstacles[0]
            lateral = abs(world.observation.ego.y_m - o.y_m)
            if o.relation == "alongside":
                min_clearance = min(min_clearance, lateral)
            passed = o.relation == "behind" and o.gap_m > 20.0
            return passed

        collisions = drive(loop, 20.0, on_step=watch)
    report(f"Scenario 1: passed the obstacle {passed},"
           f" smallest lateral centre distance alongside {min_clearance:.2f} m")
    assert passed
    assert collisions == []
    assert min_clearance > 0.5 * (1.8 + 2.0)  # the two boxes never touch sideways


def test_ego_start_pose_and_lateral_offset():
    config = straight_config(ego=EgoStart(lane="left", pos_m=80.0, speed_mps=10.0, lateral_offset_m=0.8))
    with SumoWorld(config) as world:
        x, y, phi, v = world.ego_state
        assert (x, y, phi, v) == pytest.approx((80.0 - 2.6, 3.5 + 0.8, 0.0, 10.0))
        ego = world.observation.ego
        assert (ego.x_m, ego.y_m, ego.speed_mps) == pytest.approx((x, y, 10.0))
        assert ego.lane_role == "left" and ego.lateral_offset_m == pytest.approx(0.8)
        assert world.lane(config.ego.lane)[0] == "left"
        assert default_specification(world).get("path_tracking").lane == "left"


def run_to(loop: RunLoop, duration_s: float) -> None:
    """``RunLoop.run`` to the world time ``duration_s`` (the loop's settings say when it ends)."""
    loop.settings = LoopSettings(duration_s=duration_s, stop_at_goal=False)
    loop.run()


def test_specification_swaps_are_recorded():
    with sumo_loop(straight_config(), stop_at_goal=False) as loop:
        start = loop.world.time_s
        run_to(loop, start + 0.4)
        path = loop.world.road.lane_path("left")
        loop.slot.update(lambda spec: spec.attach(PathTracking(path=path, lane="left", v_ref_mps=10.0)))
        run_to(loop, start + 0.8)
    rows = loop.recorder.trajectory_rows
    versions = [r["spec_version"] for r in rows]
    assert versions == [0] * 10 + [1] * 10
    assert "lane=center" in rows[0]["spec_summary"] and "lane=left" in rows[-1]["spec_summary"]
    assert [r["tracked_lane"] for r in rows] == ["center"] * 10 + ["left"] * 10
    frame = pd.DataFrame(rows)
    assert len(frame) == 20 and {"time_s", "x_m", "delta", "lane_id", "spec_summary", "solve_ms"} <= set(frame)
    assert frame["time_s"].to_numpy() == pytest.approx(start + 0.04 * np.arange(20))
    (event,) = loop.recorder.specification_events  # the swap, at the time it happened
    assert event["sim_time_s"] == pytest.approx(start + 0.4)


def test_sublane_model_runs(report):
    with sumo_loop(straight_config(sublane=True), stop_at_goal=False) as loop:
        assert "--lateral-resolution" in loop.world.bridge.command
        run_to(loop, loop.world.time_s + 1.0)
        assert loop.finished
    rows = loop.recorder.trajectory_rows
    assert len(rows) == 25 and sum(r["collisions"] for r in rows) == 0
    assert not loop.recorder.metrics.ego_collision_pairs


def test_failed_run_closes_sumo_and_keeps_the_records():
    loop = sumo_loop(straight_config(), stop_at_goal=False)
    run_to(loop, loop.world.time_s + 0.4)
    loop.world.bridge.remove_vehicle("ego")  # SUMO loses the ego, as when something else removes it
    expected = r"SUMO failed at t=0.48 s: .*while moving 'ego'.*not known"
    with pytest.raises(WorldError, match=expected):
        loop.step()
    assert not loop.world.running and bridge._active is None
    assert len(loop.recorder.trajectory_rows) == 10 and pd.DataFrame(loop.recorder.trajectory_rows).shape[0] == 10
    with pytest.raises(WorldError, match="closed"):
        loop.step()
    loop.close()  # idempotent after the failure
    with sumo_loop(straight_config()) as again:  # nothing left behind: SUMO starts again
        again.step()


def test_driving_off_the_end_of_the_road_keeps_running():
    """Past its last lane the ego is off-road for SUMO (lane ''), which is a state, not a failure."""
    config = straight_config(ego=EgoStart(lane="center", pos_m=560.0, speed_mps=15.0))
    with sumo_loop(config, stop_at_goal=False) as loop:
        run_to(loop, loop.world.time_s + 6.0)
        observation = loop.world.observation
        assert observation.ego.lane_id == "" and observation.ego.lane_role == ""
        assert observation.ego.x_m > 600.0


@pytest.mark.parametrize(
    ("update", "message"),
    [
        ({"ego": EgoStart(lane="center", pos_m=650.0)}, r"ego start is off the road: position 650.0 m outside"),
        ({"ego": EgoStart(lane="center", pos_m=50.0, lateral_offset_m=7.0)}, "ego start is off the road: centre"),
        ({"ego": EgoStart(lane=3)}, "ego start: lane index 3 out of range"),
        ({"ego": EgoStart(edge_id="c9")}, "ego start: edge 'c9' is not on the road"),
        ({"road": "nowhere"}, "no edge 'nowhere'"),
        ({"ego_type_id": "bus"}, r"vType 'bus' is not defined in the route files"),
        ({"obstacles": (StaticObstacle(id="o", pos_m=900.0),)}, "obstacle 'o' is off the road"),
        ({"goal_s_m": 700.0}, "goal_s_m=700.0 is not on the road"),
    ],
)
def test_bad_configs_are_refused_before_sumo_starts(update, message):
    with pytest.raises(WorldError, match=message):
        SumoWorld(straight_config(**update))
    assert bridge._active is None


def test_bad_files_are_named(tmp_path):
    with pytest.raises(WorldError, match="route file not found: .*missing.rou.xml"):
        SumoWorld(straight_config(route_files=(tmp_path / "missing.rou.xml",)))
    broken = tmp_path / "broken.net.xml"
    broken.write_text("<net><edge")
    with pytest.raises(WorldError, match="malformed network file .*broken.net.xml"):
        SumoWorld(straight_config(net_file=broken))
    with pytest.raises(WorldError, match="network file not found"):
        SumoWorld(straight_config(net_file=tmp_path / "missing.net.xml"))
    bad_routes = tmp_path / "bad.rou.xml"
    bad_routes.write_text(STRAIGHT_ROUTES.read_text().replace('<route id="road"', '<route id="road" oops'))
    with pytest.raises(WorldError, match="bad.rou.xml"):
        SumoWorld(straight_config(route_files=(bad_routes,)))
    with pytest.raises(ValueError, match="vehicle ids must be unique"):
        straight_config(vehicles=(VehicleSpawn(id="ego", pos_m=10.0),))


def test_a_vehicle_without_room_to_enter_is_reported():
    blocked = VehicleSpawn(id="blocked", lane="center", pos_m=98.0, speed_mps=15.0)  # on the ego's spot
    with pytest.warns(UserWarning, match=r"SUMO has not inserted \['blocked'\] yet"):
        with SumoWorld(straight_config(vehicles=(blocked,))) as world:
            assert world.observation.vehicle("blocked") is None


def test_the_ego_enters_at_the_speed_of_the_car_it_finds_close_ahead():
    """``match_leader_within_m`` (LaMPilot's evaluator): the leader SUMO has within that gap as the ego enters
    sets its speed, whatever the scene predicted; the ego then enters at its spot instead of far back."""
    slow_car = VehicleSpawn(id="slow", lane="center", pos_m=95.0, speed_mps=8.0, max_speed_mps=8.0, lane_changes=False)
    config = straight_config(vehicles=(slow_car,), warmup_s=2.0)
    matched = config.replace(ego=EgoStart(lane="center", pos_m=100.0, speed_mps=15.0, match_leader_within_m=50.0))
    with SumoWorld(matched) as world:
        start = world.ego_start
        assert start["pos_m"] == 100.0 and start["inserted_at_s"] == pytest.approx(2.04)
        assert 0.0 < start["speed_mps"] <= 8.0 and world.ego_state[3] == start["speed_mps"]
        assert world.observation.ego.speed_mps == pytest.approx(start["speed_mps"])
    with SumoWorld(config.replace(ego=EgoStart(lane="center", pos_m=100.0, speed_mps=15.0))) as world:
        assert "speed_mps" not in world.ego_start  # not asked: the configured speed, SUMO finding the room
        assert world.ego_state[3] == 15.0
    far = matched.replace(ego=EgoStart(lane="center", pos_m=100.0, speed_mps=15.0, match_leader_within_m=5.0))
    with SumoWorld(far) as world:  # the car is further ahead than that: the configured speed
        assert world.ego_state[3] == 15.0
