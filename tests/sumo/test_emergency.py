"""Scenario 2 against real SUMO: an ambulance approaches from behind; does the ego let it pass?"""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from agentic_mpc.primitives import PathTracking
from agentic_mpc.run.loop import RunLoop
from agentic_mpc.sumo.config import EgoStart
from agentic_mpc.sumo.scenarios import scenario2_config
from tests.sumo.conftest import drive, sumo_loop

MARK_S_M = 650.0
"""The ambulance's travel time is measured from its start to this along-road position."""


def test_ambulance_is_observed_with_its_distance_and_closing_speed(report):
    with sumo_loop(scenario2_config(lefthand=True)) as loop:
        sumo = loop.world.bridge
        ego_length = loop.world.ego_length_m
        worst_distance = worst_closing = 0.0
        for _ in range(100):
            loop.step()
            observation = loop.world.observation
            (ambulance,) = observation.emergency_vehicles
            assert ambulance.vehicle.id == "ambulance" and ambulance.vehicle.vclass == "emergency"
            assert ambulance.relation == "behind" and ambulance.same_lane
            # Ground truth from SUMO itself: lane positions (front bumpers) on this straight road ...
            ego_state, amb_state = sumo.vehicle_state("ego"), sumo.vehicle_state("ambulance")
            truth = ego_state.lane_pos_m - ego_length - amb_state.lane_pos_m
            worst_distance = max(worst_distance, abs(ambulance.distance_m - truth))
            # ... and SUMO's follower query (its gap excludes the follower's minGap).
            follower, gap = sumo.follower("ego")
            assert follower == "ambulance"
            assert ambulance.distance_m == pytest.approx(gap + sumo.min_gap_m("ambulance"), abs=0.05)
            closing_truth = amb_state.speed_mps - ego_state.speed_mps
            worst_closing = max(worst_closing, abs(ambulance.closing_speed_mps - closing_truth))
            if ambulance.closing_speed_mps > 0:
                assert ambulance.time_to_reach_s == pytest.approx(ambulance.distance_m / ambulance.closing_speed_mps)
        first = loop.recorder.trajectory_rows[0]
    report(
        f"ambulance behind the ego: last distance {ambulance.distance_m:.2f} m,"
        f" closing {ambulance.closing_speed_mps:.2f}"
        f" m/s; worst error against SUMO over 100 steps: distance {worst_distance:.2e} m,"
        f" closing speed {worst_closing:.2e} m/s (first step at t={first['time_s']:.2f} s)"
    )
    assert worst_distance < 0.05
    assert worst_closing < 0.05


def run_scenario2(lefthand: bool, yield_lane: str | None, resume: bool = False, seed: int = 0,
                  yield_after_s: float = 2.0) -> dict:
    """Drive Scenario 2; ``yield_lane``: switch J1 to that lane with v_ref = 0 after ``yield_after_s`` (the
    paper's run_left_lane(0)); ``resume``: back to the centre lane at 15 m/s once the ambulance is 60 m ahead
    (the paper's run_center_lane(15)). Returns the ambulance's travel time to :data:`MARK_S_M` and more."""
    with sumo_loop(scenario2_config(lefthand=lefthand), seed=seed, stop_at_goal=False) as loop:
        world = loop.world
        start = world.time_s
        ambulance_start_s = world.observation.emergency_vehicles[0].vehicle.road_s_m
        out: dict = {"relations": set(), "ambulance_min_speed": np.inf}

        def on_step(loop: RunLoop, outcome) -> bool:
            t = outcome.observation.time_s - start
            if yield_lane and loop.slot.version == 0 and t >= yield_after_s:
                path = world.road.lane_path(yield_lane)
                loop.slot.update(lambda spec: spec.attach(PathTracking(path=path, lane=yield_lane, v_ref_mps=0.0)))
                out["yield_at_s"] = t
            emergency = world.observation.emergency_vehicles
            if emergency:
                ambulance = emergency[0]
                out["relations"].add(ambulance.relation)
                out["ambulance_min_speed"] = min(out["ambulance_min_speed"], ambulance.vehicle.speed_mps)
                if ambulance.vehicle.road_s_m >= MARK_S_M and "ambulance_time_s" not in out:
                    out["ambulance_time_s"] = t
                    out["relation_at_mark"] = ambulance.relation
                if resume and loop.slot.version == 1 and ambulance.relation == "ahead" and ambulance.distance_m > 60.0:
                    path = world.road.lane_path("center")
                    loop.slot.update(lambda spec: spec.attach(PathTracking(path=path, lane="center", v_ref_mps=15.0)))
                    out["resumed_at_s"] = t
            if "ambulance_time_s" in out and not resume:
                return True
            return resume and "resumed_at_s" in out and t > out["resumed_at_s"] + 15.0

        collisions = drive(loop, 90.0, on_step=on_step)
        ego = world.observation.ego
        out.update(
            ambulance_start_s=ambulance_start_s,
            ego_lane=ego.lane_role,
            ego_speed=ego.speed_mps,
            stopped_for_s=sum(1 for r in loop.recorder.trajectory_rows if r["v_mps"] < 0.1) * 0.04,
            collisions=collisions,
        )
    return out


def free_flow_time_s(lefthand: bool) -> float:
    """The ambulance's travel time to the mark with nobody in its way (the ego far ahead in the left lane)."""
    config = scenario2_config(lefthand=lefthand, roadblock=False).replace(
        ego=EgoStart(lane="left", pos_m=720.0, speed_mps=15.0), goal_s_m=790.0
    )
    with sumo_loop(config, stop_at_goal=False) as loop:
        world = loop.world
        start = world.time_s

        def at_mark(loop: RunLoop, outcome) -> bool:
            return world.observation.emergency_vehicles[0].vehicle.road_s_m >= MARK_S_M

        drive(loop, 60.0, on_step=at_mark)
        return world.time_s - start


@pytest.mark.parametrize("lefthand", [True, False], ids=["left-hand (paper)", "right-hand"])
def test_ambulance_is_delayed_when_the_ego_holds_its_lane_and_passes_when_it_yields(report, lefthand):
    free = free_flow_time_s(lefthand)
    hold = run_scenario2(lefthand, yield_lane=None)
    give_way = run_scenario2(lefthand, yield_lane="left")
    report(
        f"{'left' if lefthand else 'right'}-hand road, ambulance travel time to s={MARK_S_M:.0f} m"
        f" (from s={hold['ambulance_start_s']:.1f} m): free {free:.2f} s;"
        f" ego holds the centre lane {hold['ambulance_time_s']:.2f} s (delay {hold['ambulance_time_s'] - free:+.2f} s,"
        f" ambulance slowed to {hold['ambulance_min_speed']:.1f} m/s);"
        f" ego moves to the left lane and stops {give_way['ambulance_time_s']:.2f} s"
        f" (delay {give_way['ambulance_time_s'] - free:+.2f} s), ego ended in the {give_way['ego_lane']} lane at"
        f" {give_way['ego_speed']:.2f} m/s"
    )
    assert hold["collisions"] == [] and give_way["collisions"] == []
    # Holding the lane: the ambulance never gets past and is measurably late.
    assert hold["relations"] == {"behind"} and hold["relation_at_mark"] == "behind"
    assert hold["ambulance_time_s"] - free > 8.0
    assert hold["ego_lane"] == "center"
    # Yielding: the ego stands in the left lane, the ambulance passes it and is much earlier.
    assert give_way["ego_lane"] == "left" and give_way["ego_speed"] < 0.1
    assert give_way["relation_at_mark"] == "ahead"
    assert give_way["ambulance_time_s"] < hold["ambulance_time_s"] - 3.0


def test_ego_resumes_the_centre_lane_after_the_ambulance_passed(report):
    """The paper's whole Scenario 2: run_left_lane(0) when the ambulance comes, run_center_lane(15) when gone."""
    result = run_scenario2(lefthand=True, yield_lane="left", resume=True)
    report(
        f"yield at t={result['yield_at_s']:.2f} s, stood still {result['stopped_for_s']:.1f} s, resumed at"
        f" t={result['resumed_at_s']:.2f} s; 15 s later: {result['ego_lane']} lane at {result['ego_speed']:.2f} m/s"
    )
    assert result["collisions"] == []
    assert result["stopped_for_s"] > 1.0
    assert result["ego_lane"] == "center" and result["ego_speed"] > 13.0


@pytest.mark.slow
def hold_and_yield(seeds: range) -> list[tuple[dict, dict]]:
    """Scenario 2 held and yielded for each seed, in this process (one simulation after the other)."""
    return [(run_scenario2(True, None, seed=seed), run_scenario2(True, "left", seed=seed)) for seed in seeds]


def test_yielding_helps_the_ambulance_over_ten_seeds(report):
    # two processes, five seeds each (libsumo runs one simulation at a time per process)
    context = multiprocessing.get_context("forkserver")
    with ProcessPoolExecutor(max_workers=2, mp_context=context, max_tasks_per_child=1) as pool:
        pairs = [pair for chunk in pool.map(hold_and_yield, [range(0, 10, 2), range(1, 10, 2)]) for pair in chunk]
    holds, yields = [], []
    for hold, give_way in pairs:
        assert hold["collisions"] == [] and give_way["collisions"] == []
        assert give_way["ego_lane"] == "left" and give_way["relation_at_mark"] == "ahead"
        assert hold["relation_at_mark"] == "behind"
        holds.append(hold["ambulance_time_s"])
        yields.append(give_way["ambulance_time_s"])
    report(
        f"ambulance time to s={MARK_S_M:.0f} m over 10 seeds: holding {np.mean(holds):.2f} +- {np.std(holds):.2f} s"
        f" (min {min(holds):.2f}), yielding {np.mean(yields):.2f} +- {np.std(yields):.2f} s (max {max(yields):.2f})"
    )
    assert max(yields) < min(holds) - 2.0
