"""The agent through its MCP server: the paper's agent steps, lockstep timing, observation messages, transcript."""

from __future__ import annotations

import json
import os
import sys

import numpy as np
import pytest
from mcp import StdioServerParameters

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.run.loop import AgentSetup
from tests.agent.conftest import ambulance_loop

PAPER_1 = "Let's try to avoid obstacles from the right, shall we?"
PAPER_2A = "An ambulance is coming behind us. We'd better let them pass."
PAPER_2B = "Thank you. The ambulance is gone."


def test_system_message_holds_the_initial_primitives_and_the_tools(loop, server):
    with Agent(RulesBackend(), server) as agent:
        system = agent.history.messages[0]
    assert system.role == "system" and system.tau == 0
    assert "path_tracking (J1): lane=center, v_ref_mps=15.0" in system.content
    assert "obstacle_avoidance (J2)" in system.content
    for tool in ("run_center_lane(v_ref: number in [0.0, 25.0])", "run_left_lane", "set_preferred_steering_direction"):
        assert tool in system.content
    assert system.data["initial_specification"]["attached"][1]["v_ref_mps"] == 15.0


def test_paper_scenario_1_message_attaches_j3(loop, server):
    with Agent(RulesBackend(), server) as agent:
        report = agent.deliver(PAPER_1).result(10)
    assert report.applied_calls == [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "right"}}]
    assert loop.slot.current.get("preferred_steering_direction").direction == "right"
    # tau: system 0, user 1, agent message with the call 2, tool result 3, closing agent message 4
    roles = [(m.tau, m.role) for m in agent.history.messages]
    assert roles == [(0, "system"), (1, "user"), (2, "assistant"), (3, "tool"), (4, "assistant")]
    assert agent.history.messages[2].tool_calls[0].name == "set_preferred_steering_direction"
    assert not agent.history.messages[4].tool_calls and report.ended == "idle"


def test_paper_scenario_2_in_realtime_restores_the_original_specification(loop, server):
    with Agent(RulesBackend(), server) as agent:
        first = agent.deliver(PAPER_2A).result(10)
        assert loop.slot.current.get("path_tracking").lane == "left"
        assert loop.slot.current.get("path_tracking").v_ref_mps == 0.0
        second = agent.deliver(PAPER_2B).result(10)
    assert first.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert second.applied_calls == [{"tool": "run_center_lane", "arguments": {"v_ref": 15}}]
    assert loop.slot.current == loop.slot.initial  # the original specification, exactly
    assert (first.first_tau, second.first_tau) == (1, 5)


def _lockstep_run(tmp_path, name, latency_s=0.6):
    loop = ambulance_loop()
    config = AgentConfig(mode="lockstep", latency_s=latency_s, transcript_path=tmp_path / f"{name}.jsonl")
    messages = {50: PAPER_2A, 400: PAPER_2B}  # at t = 2.0 s and t = 16.0 s
    lanes = []
    with loop, Agent(RulesBackend(), loop.server, config) as agent:
        for k in range(500):
            if k in messages:
                report = agent.deliver(messages[k], sim_time_s=loop.world.time_s).result(0)  # lockstep: already done
                assert report.ended == "idle"
            loop.step()
            lanes.append(loop.slot.current.get("path_tracking").lane)  # the lane step k drove on
    return loop, agent, lanes


def test_lockstep_applies_calls_after_the_latency_and_is_deterministic(tmp_path):
    loop_a, agent_a, lanes_a = _lockstep_run(tmp_path, "a")
    loop_b, agent_b, lanes_b = _lockstep_run(tmp_path, "b")
    # the decision at t = 2.0 s takes effect at 2.6 s: steps 65 (t = 2.6 s) and after
    assert lanes_a[64] == "center" and lanes_a[65] == "left"
    assert lanes_a[414] == "left" and lanes_a[415] == "center"  # 16.0 + 0.6 = 16.6 s
    assert lanes_a == lanes_b
    assert np.array_equal(loop_a.world.ego_state, loop_b.world.ego_state)  # bit for bit
    calls_a = [r for r in agent_a.transcript.records if r["event"] == "tool_call"]
    assert [(r["tool"], r["arguments"], r["sim_time_s"], r["apply_at_s"]) for r in calls_a] == [
        ("run_left_lane", {"v_ref": 0}, 2.0, 2.6),
        ("run_center_lane", {"v_ref": 15}, 16.0, 16.6),
    ]


def test_transcript_records_every_message_call_and_result(tmp_path):
    _, agent, _ = _lockstep_run(tmp_path, "t")
    lines = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    assert lines == agent.transcript.records
    events = [r["event"] for r in lines]
    assert events[0] == "message" and lines[0]["role"] == "system" and lines[0]["tau"] == 0
    assert events.count("tool_call") == 2 and events.count("tool_result") == 2 and events.count("step_end") == 2
    users = [r for r in lines if r["event"] == "message" and r["role"] == "user"]
    assert [(u["tau"], u["sim_time_s"], u["content"]) for u in users] == [(1, 2.0, PAPER_2A), (5, 16.0, PAPER_2B)]
    result = next(r for r in lines if r["event"] == "tool_result")
    assert result["is_error"] is False and result["result"]["apply_at_s"] == 2.6
    assert all({"event", "tau", "sim_time_s", "wall_time_s"} <= set(r) for r in lines)


def test_emergency_vehicle_wakes_the_agent_and_the_car_makes_way_then_resumes(tmp_path):
    config = AgentConfig(mode="lockstep", latency_s=0.5, transcript_path=tmp_path / "wake.jsonl")
    closest_y = []
    collided = False
    with ambulance_loop(agent=AgentSetup(RulesBackend(), config.model_copy(update={"observation_messages": True}))) as loop:
        agent, world = loop.agent, loop.world
        for _ in range(1250):  # 50 s
            loop.step()
            ambulance = world.observation.emergency_vehicles
            if ambulance and abs(ambulance[0].vehicle.x_m - world.ego_state[0]) < 5.0:
                closest_y.append(world.ego_state[1])
            collided |= world.observation.ego_collided
    observations = [m for m in agent.history.messages if m.source == "observation"]
    assert [m.content.split(": ", 1)[1][:40] for m in observations] == [
        "An emergency vehicle (ambulance 'ambulan",
        "The emergency vehicle (ambulance 'ambula",
    ]
    calls = [r for r in agent.transcript.records if r["event"] == "tool_call"]
    assert [(c["tool"], c["arguments"]) for c in calls] == [
        ("run_left_lane", {"v_ref": 0}), ("run_center_lane", {"v_ref": 15})
    ]
    # the ambulance passed while the ego was in the left lane, and no one collided
    assert closest_y and min(closest_y) > 2.0 and not collided
    assert loop.slot.current == loop.slot.initial
    assert world.ego_state[3] > 12.0 and abs(world.ego_state[1]) < 0.5  # driving again, back in the centre lane


def test_observations_do_not_wake_the_agent_by_default():
    with ambulance_loop(agent=AgentSetup(RulesBackend(), AgentConfig(mode="lockstep"))) as loop:
        for _ in range(200):  # 8 s: the ambulance comes within the alert distance
            loop.step()
        assert "emergency_vehicle_approaching" in loop.detector.first_times_s
        assert len(loop.agent.history) == 1  # only the system message: no observation message


def test_the_agent_can_reach_its_server_in_another_process():
    params = StdioServerParameters(
        command=sys.executable,
        args=["-m", "agentic_mpc.commands.serve", "--transport", "stdio", "--ambulance-at-s", "-1"],
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    )
    with Agent(RulesBackend(), params, AgentConfig(startup_timeout_s=60)) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert report.tool_calls[0]["result"]["attached"][1]["lane"] == "left"


@pytest.mark.parametrize("timing", ["realtime", "lockstep"])
def test_steps_are_processed_in_order(loop, server, timing):
    config = AgentConfig(mode=timing, latency_s=0.0)
    with Agent(RulesBackend(), server, config) as agent:
        futures = [agent.deliver(text, sim_time_s=0.0) for text in ("go 5 m/s", "go 6 m/s", "go 7 m/s")]
        reports = [f.result(10) for f in futures]
        loop.tools.apply_due(0.0)
    assert [r.applied_calls[0]["arguments"]["v_ref"] for r in reports] == [5, 6, 7]
    assert loop.slot.current.get("path_tracking").v_ref_mps == 7.0
