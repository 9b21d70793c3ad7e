"""The agent reads the situation through MCP resources and wakes itself on emergency vehicles it watches there:
in-process (lockstep and realtime, subscribed to the resource) and across a process boundary over HTTP."""

from __future__ import annotations

import threading
import time

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.agent.situation import describe_situation
from agentic_mpc.run.loop import AgentSetup, LoopSettings, RunLoop
from agentic_mpc.world.emergency import EmergencyEvent
from agentic_mpc.world.plain import PlainWorld
from tests.agent.conftest import ambulance_config, ambulance_loop, paper_specification
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call
from tests.mcp.test_http_security import Served

EGO = {"time_s": 12.34, "ego": {"id": "ego", "speed_mps": 14.8, "lane_role": "center", "lateral_offset_m": -0.6}}
AMBULANCE = {"time_s": 12.34, "emergency_vehicles": [
    {"id": "amb0", "type_id": "ambulance", "relation": "behind", "distance_m": 45.2, "lane_role": "center"}]}
SPEC = {"summary": "path_tracking(lane=center, v_ref_mps=15); obstacle_avoidance(1 obstacle)"}


def test_the_situation_in_a_few_lines_from_the_resources_json():
    said = describe_situation(EGO, AMBULANCE, SPEC)
    assert said.splitlines() == [
        "Current situation (t = 12.3 s):",
        "- we drive at 14.8 m/s (53 km/h) in the center lane 0.6 m right of its centre",
        "- emergency vehicle ambulance 'amb0' 45 m behind us, in the center lane",
        "- attached: path_tracking(lane=center, v_ref_mps=15); obstacle_avoidance(1 obstacle)",
    ]
    assert "no emergency vehicle around" in describe_situation(EGO, {"emergency_vehicles": []}, None)
    assert describe_situation(None, None, None) is None  # a server without the resources


def test_the_car_ahead_and_the_lanes_beside_us_for_the_manoeuvre_tools():
    ego = {"time_s": 3.1, "ego": {"speed_mps": 31.3, "lane_role": "center", "lane_index": 1}}
    traffic = {"vehicles": [
        {"id": "car2", "relation": "ahead", "relative_lane": 0, "gap_m": 42.4, "speed_mps": 27.1},
        {"id": "car5", "relation": "ahead", "relative_lane": 0, "gap_m": 140.0, "speed_mps": 20.0},
        {"id": "car1", "relation": "ahead", "relative_lane": 1, "gap_m": 10.0, "speed_mps": 30.0}]}
    road = {"lefthand": False, "emergency_lane": "right", "lanes": [  # from the road edge outwards
        {"name": "right", "index": 0}, {"name": "center", "index": 1}, {"name": "left", "index": 2}]}
    lines = describe_situation(ego, None, None, traffic, road).splitlines()
    assert lines[2] == "- lanes to our left: 1, to our right: 1 (the right-most of them the emergency lane)"
    assert lines[3] == "- car ahead in our lane: 'car2' 42 m ahead (bumper to bumper) at 27.1 m/s"
    lonely = describe_situation(ego, None, None, {"vehicles": traffic["vehicles"][1:]}, None)
    assert "- no car ahead in our lane within 100 m" in lonely


def test_a_language_model_gets_the_situation_read_over_mcp_with_the_message(loop, server):
    for _ in range(50):  # 2 s of driving: the situation has a time and a speed
        loop.step()
    script = [calls(tool_call("set_reference_speed", {"v_ref": 10}, "c1")), text("Slower now.")]
    with ScriptedLLM(script) as llm, Agent(OpenAIBackend(OpenAISettings(base_url=llm.base_url, api_key_env=None)),
                                           server) as agent:
        report = agent.deliver("Please slow down to 36 km/h.").result(30)
    assert report.applied_calls == [{"tool": "set_reference_speed", "arguments": {"v_ref": 10}}]
    user = llm.requests[0]["messages"][1]
    assert user["role"] == "user" and user["content"].startswith("Current situation (t = 2.0 s):")
    assert "in the center lane" in user["content"]
    # the compact prompt's situation: what is as at the start (no emergency vehicle, the attached
    # specification, the lanes the system message gives) is left out; the transcript keeps all of it
    assert "no emergency vehicle around" not in user["content"] and "attached" not in user["content"]
    assert user["content"].endswith("\n\nPassenger: Please slow down to 36 km/h.")
    recorded = next(r for r in agent.transcript.records if r.get("role") == "user")
    assert recorded["content"] == "Please slow down to 36 km/h." and recorded["context"].startswith("Current")
    assert "no emergency vehicle around" in recorded["context"]
    assert "- attached: path_tracking(lane=center, v_ref_mps=15)" in recorded["context"]


def test_the_rules_backend_is_given_no_situation(loop, server):
    with Agent(RulesBackend(), server) as agent:
        agent.deliver("Please slow down to 36 km/h.").result(30)
    assert "context" not in next(r for r in agent.transcript.records if r.get("role") == "user")


def test_a_realtime_agent_subscribed_to_emergency_vehicles_wakes_itself_and_makes_way():
    config = AgentConfig(mode="realtime")
    with ambulance_loop(agent=AgentSetup(RulesBackend(), config.model_copy(update={"observation_messages": True})), pace=0.25) as loop:
        driving = threading.Thread(target=loop.run, daemon=True)
        driving.start()
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and "lane=left" not in loop.slot.current.summary():
            time.sleep(0.1)
        loop.stop.set()
        driving.join(10)
        observations = [m for m in loop.agent.history.messages if m.source == "observation"]
    assert observations and "is approaching from behind" in observations[0].content
    # it read the ambulance within the alert distance (80 m), as the loop's own detector saw it
    seen_at = float(observations[0].content.split("t = ")[1].split(" s")[0])
    assert abs(seen_at - loop.detector.first_times_s["emergency_vehicle_approaching"]) < 0.5
    assert "lane=left" in loop.slot.current.summary()


def test_an_agent_in_another_process_watches_the_server_over_http(tmp_path):
    served = Served(tmp_path, "--ambulance-at-s", "1", "--time-scale", "0.25", "--duration-s", "120")
    try:
        config = AgentConfig(mode="realtime", observation_messages=True)
        with Agent(RulesBackend(yield_lane="left"), served.url, config) as agent:
            deadline = time.monotonic() + 40
            while time.monotonic() < deadline and not any(
                    r.get("event") == "tool_call" for r in agent.transcript.records):
                time.sleep(0.2)
            records = agent.transcript.records
    finally:
        served.stop()
    woke = [r for r in records if r.get("event") == "message" and r.get("source") == "observation"]
    assert woke and "is approaching from behind" in woke[0]["content"]
    assert [r["tool"] for r in records if r.get("event") == "tool_call"][:1] == ["run_left_lane"]


def test_the_agent_is_woken_by_what_the_runs_one_detector_decided():
    # one decision, one alert distance (the run's, here 40 m, not the default 80 m): the agent relays it
    world = PlainWorld(ambulance_config(), seed=0)
    settings = LoopSettings(duration_s=3600.0, stop_at_goal=False, alert_distance_m=40.0)
    agent = AgentSetup(RulesBackend(), AgentConfig(mode="lockstep", observation_messages=True))
    with RunLoop(world, paper_specification(world), settings, agent=agent) as loop:
        while not loop.detector.events and world.time_s < 30.0:
            loop.step()
        observations = [m for m in loop.agent.history.messages if m.source == "observation"]
    (approaching,) = loop.detector.events
    assert approaching.distance_m <= 40.0
    assert [(m.content, m.sim_time_s) for m in observations] == [
        (EmergencyEvent.from_json(approaching.to_json()).message(), round(approaching.time_s, 3))]


def test_a_tactic_that_shapes_path_tracking_is_a_line_of_the_situation():
    tactics = {"rules": ["pass_beside_queue"], "active": {"rule": "pass_beside_queue", "obstacle_id": "stopped",
                                                          "tracked_lane": 1, "followed_lane": 0, "since_s": 3.0}}
    said = describe_situation(EGO, None, SPEC, tactics=tactics)
    assert "- tactic pass_beside_queue: path tracking follows lane 0 instead of lane 1 to pass stopped" in said
    assert "tactic" not in describe_situation(EGO, None, SPEC, tactics={"rules": [], "active": None})


def test_an_emergency_vehicle_ahead_of_us_is_said_to_need_no_way():
    passed = {"emergency_vehicles": [{"id": "amb0", "type_id": "ambulance", "relation": "ahead", "distance_m": 41.0,
                                      "lane_role": "center"}]}
    assert ("- emergency vehicle ambulance 'amb0' 41 m ahead of us (past us: it needs no way from us), in the "
            "center lane") in describe_situation(EGO, passed, None).splitlines()
