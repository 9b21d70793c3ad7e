"""The tactics layer: rules chosen by name, removed switches refused, and what a tactic changes made visible
(the plan, ``mpc://tactics``, ``events.csv`` rows, the agent's situation line, the replay's captions)."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.scenario.yaml_source import ScenarioFileError
from agentic_mpc.tactics.config import ALL_RULES, TacticsConfig

REPO = Path(__file__).resolve().parents[2]
INCIDENT = REPO / "scenarios" / "incident_in_traffic.yaml"


def scenario_with(tmp_path: Path, extra: str) -> Path:
    """The incident scenario with ``extra`` lines appended (top-level YAML), beside a link to the nets."""
    (tmp_path / "sumo_nets").symlink_to(REPO / "sumo_nets", target_is_directory=True)
    (tmp_path / "scenarios").mkdir()
    path = tmp_path / "scenarios" / "incident.yaml"
    path.write_text(INCIDENT.read_text(encoding="utf-8") + extra, encoding="utf-8")
    return path


def problems_of(path: Path) -> str:
    with pytest.raises(ScenarioFileError) as error:
        load_scenario(path)
    return str(error.value)


def test_the_default_rules_are_all_of_them_and_a_scenario_chooses_by_name(tmp_path):
    assert load_scenario(INCIDENT).variant("left").tactics.rules == ALL_RULES
    path = scenario_with(tmp_path, "tactics:\n  rules: [queue_room, passing_lanes]\n"
                                   "  passing_lanes: {within_m: 60.0}\n")
    tactics = load_scenario(path).variant("left").tactics
    assert tactics.rules == ("queue_room", "passing_lanes") and tactics.passing_lanes.within_m == 60.0
    assert not tactics.uses("merge_ahead_of_queue")


def test_an_unknown_rule_fails_with_the_file_line_and_the_known_names(tmp_path):
    path = scenario_with(tmp_path, "tactics:\n  rules: [queue_room, zipper_merge]\n")
    problems = problems_of(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    assert f"incident.yaml:{len(lines)}: tactics.rules" in problems
    assert "zipper_merge" in problems and all(name in problems for name in ALL_RULES)
    with pytest.raises(ValueError, match="named twice"):
        TacticsConfig(rules=("queue_room", "queue_room"))


@pytest.mark.parametrize(("where", "key", "says"), [
    ("simulation.surroundings", "approach_decel_mps2", "docs/history.md#switches-removed-on-2026-12-06"),
    ("simulation.surroundings", "lane_neighbours", "docs/history.md#switches-removed-on-2026-12-06"),
    ("simulation", "ego_standing_min_gap_m", "docs/history.md#switches-removed-on-2026-12-06"),
    ("simulation.surroundings", "detour_ahead_of_queues_m", "tactics: {merge_ahead_of_queue"),
    ("simulation.surroundings", "follower_yield_mps2", "tactics: {gap_acceptance"),
])
def test_a_removed_or_moved_switch_fails_check_saying_where_it_went(tmp_path, where, key, says):
    path = scenario_with(tmp_path, "")
    text = path.read_text(encoding="utf-8")
    if where == "simulation":
        text = text.replace("simulation:\n", f"simulation:\n  {key}: 1.0\n", 1)
    else:
        text = text.replace("  surroundings: {edges: corridor}", f"  surroundings: {{edges: corridor, {key}: 1.0}}")
    path.write_text(text, encoding="utf-8")
    problems = problems_of(path)
    assert "incident.yaml:" in problems and f": {where}" in problems
    assert f"{key!r} was removed" in problems and says in problems
    # the command a user runs says the same and runs nothing
    out = subprocess.run([sys.executable, "-m", "agentic_mpc.cli", "check", str(path)], capture_output=True, text=True,
                         check=False)
    assert out.returncode != 0 and says in out.stdout + out.stderr and "Traceback" not in out.stderr


@pytest.mark.parametrize(("field", "key"), [("controller", "standstill_winner"),
                                            ("specification.mandatory", "lane_entry_gap_weight")])
def test_removed_controller_and_j0_switches_fail_too(tmp_path, field, key):
    path = scenario_with(tmp_path, "")
    text = path.read_text(encoding="utf-8")
    if field == "controller":
        text += f"controller: {{{key}: true}}\n"
    else:
        text = text.replace("specification:\n", f"specification:\n  mandatory: {{{key}: 1.0}}\n", 1)
    path.write_text(text, encoding="utf-8")
    problems = problems_of(path)
    assert f"{key!r} was removed" in problems and "docs/history.md#switches-removed-on-2026-12-06" in problems


def queue_in_the_centre_lane_ego_beside():
    """The curved road: a stopped car 280 m in, two cars queued behind it in the centre lane, the ego in the right
    lane 60 m back at 15 m/s."""
    from agentic_mpc.sumo.config import EgoStart, StaticObstacle, SumoConfig, SurroundingsConfig, VehicleSpawn
    from agentic_mpc.sumo.scenarios import net_files

    net, routes = net_files("curvy")
    queue = (VehicleSpawn(id="queued1", lane="center", pos_m=273.0, lane_changes=False),
             VehicleSpawn(id="queued2", lane="center", pos_m=266.0, lane_changes=False))
    return SumoConfig(net_file=net, route_files=(routes,), road="curvy", vehicles=queue,
                      obstacles=(StaticObstacle(id="stopped", lane="center", pos_m=280.0),),
                      ego=EgoStart(lane="right", pos_m=220.0, speed_mps=15.0),
                      surroundings=SurroundingsConfig(edges="corridor"))


def test_a_detour_is_a_plan_an_event_a_resource_and_a_situation_line():
    """The ego in the right lane, a queue ahead in the centre lane J1 tracks: ``pass_beside_queue`` starts (J1 on
    the right lane), the layer says so in its event rows, its JSON and its situation line; past the stopped car it
    ends. Without the rule, nothing starts."""
    from agentic_mpc.sumo.world import SumoWorld
    from agentic_mpc.tactics.layer import TacticsLayer

    with SumoWorld(queue_in_the_centre_lane_ego_beside()) as world:
        observation = world.observation
        layer = TacticsLayer(TacticsConfig(), world.tactical_road)
        plan = layer.plan(observation, tracked_lane=1)
        assert plan.followed_lane == 0 and plan.queue_room and plan.gap_acceptance is not None
        assert plan.passing_lanes == frozenset()  # the queue is in neither the lane it drives nor the one it follows
        assert plan.active.rule == "pass_beside_queue" and plan.active.obstacle_id == "stopped"
        (started,) = layer.changes
        assert started["event"] == "tactic_started" and started["content"] == "pass_beside_queue"
        assert json.loads(started["result"])["followed_lane"] == 0
        assert layer.to_json()["active"]["rule"] == "pass_beside_queue"
        assert "J1 follows lane 0 instead of lane 1 to pass stopped" in layer.situation()
        layer.plan(observation, tracked_lane=1)
        assert len(layer.changes) == 1  # the same tactic goes on: no new row
        past = dataclasses.replace(observation, time_s=observation.time_s + 5.0, obstacles=tuple(
            dataclasses.replace(o, relation="behind") for o in observation.obstacles))
        assert layer.plan(past, tracked_lane=1).followed_lane is None
        assert [c["event"] for c in layer.changes] == ["tactic_started", "tactic_ended"]
        assert layer.to_json()["active"] is None and layer.situation() is None
        without = TacticsLayer(TacticsConfig(rules=("queue_room", "passing_lanes")), world.tactical_road)
        plan = without.plan(observation, tracked_lane=1)
        assert plan.followed_lane is None and plan.gap_acceptance is None and without.changes == []
        nothing = TacticsLayer(TacticsConfig(rules=()), world.tactical_road).plan(observation, tracked_lane=1)
        assert nothing.queues == () and nothing.passing_lanes == frozenset() and not nothing.queue_room


def test_a_tactic_in_a_run_is_read_over_mcp_recorded_and_captioned():
    """Under the run loop with real SUMO: the ego in the right lane, J1 on the centre lane where a queue stands
    ahead. The first step starts ``pass_beside_queue``: ``mpc://tactics`` (read by an MCP client) names it and the
    lane J1 follows, the recorder keeps its ``tactic_started`` row, and the replay captions it."""
    import asyncio

    from mcp import Client

    from agentic_mpc.primitives import PathTracking, Specification
    from agentic_mpc.replay.data import captions_of
    from agentic_mpc.run.loop import LoopSettings, RunLoop
    from agentic_mpc.sumo.world import SumoWorld

    world = SumoWorld(queue_in_the_centre_lane_ego_beside())
    specification = Specification.of(PathTracking(path=world.lane("center")[1], lane="center", v_ref_mps=15.0))
    with RunLoop(world, specification, LoopSettings(duration_s=60.0)) as loop:
        outcome = loop.step()

        async def read() -> dict:
            async with Client(loop.server.mcp_server, cache=None) as client:
                return json.loads((await client.read_resource("mpc://tactics")).contents[0].text)

        tactics = asyncio.run(asyncio.wait_for(read(), 60))
    assert tactics["rules"] == list(ALL_RULES)
    assert tactics["active"]["rule"] == "pass_beside_queue" and tactics["active"]["followed_lane"] == 0
    (row,) = loop.recorder.tactic_events
    assert row["event"] == "tactic_started" and row["sim_time_s"] == pytest.approx(outcome.observation.time_s)
    (caption,) = captions_of(loop.recorder.tactic_events)
    assert caption["kind"] == "tactic" and "pass_beside_queue" in caption["text"] and "lane 0" in caption["text"]
