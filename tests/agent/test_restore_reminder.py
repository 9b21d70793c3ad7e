"""The restore reminder: a step whose answer calls no tool while the specification differs from the initial
one gets one more round with a note saying how (``AgentConfig.restore_reminder``)."""

from __future__ import annotations

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.prompt import restore_note, specification_changes
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call

YIELD = "An ambulance is coming behind us. We'd better let them pass."
GONE = "OK, it has passed, carry on."


ON = AgentConfig(restore_reminder=True)


def backend(llm: ScriptedLLM) -> OpenAIBackend:
    # the model answers its results itself (not agent/backends/follow_up.py's reply written from them)
    return OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="scripted", api_key_env=None,
                                        confirmation="model"))


def _yield_script() -> list:
    return [calls(tool_call("run_left_lane", {"v_ref": 0}, "c1")), text("Pulling over.")]


def test_specification_changes_name_what_differs_from_the_initial_one():
    initial = {"attached": [{"kind": "mandatory", "symbol": "J0", "weight": 1.0},
                            {"kind": "path_tracking", "symbol": "J1", "lane": "center", "v_ref_mps": 15.0},
                            {"kind": "obstacle_avoidance", "symbol": "J2", "obstacles": [1, 2]}]}
    yielded = {"attached": [{"kind": "mandatory", "symbol": "J0", "weight": 1.0},
                            {"kind": "path_tracking", "symbol": "J1", "lane": "left", "v_ref_mps": 0.0},
                            {"kind": "obstacle_avoidance", "symbol": "J2", "obstacles": [1, 2, 3]},
                            {"kind": "preferred_steering_direction", "symbol": "J3", "direction": "right"}]}
    assert specification_changes(initial, initial) == []
    assert specification_changes(initial, None) == [] and specification_changes(None, yielded) == []
    changes = specification_changes(initial, yielded)
    assert changes == ["path_tracking: lane=left (initially center), v_ref_mps=0 (initially 15)",
                       "preferred_steering_direction(direction=right) is attached (not initially)"]
    detached = specification_changes(yielded, initial)[-1]
    assert detached == "preferred_steering_direction is detached (initially attached)"
    note = restore_note(changes)
    assert "lane=left (initially center)" in note and "reply without a call" in note


def test_an_answer_without_a_call_while_changed_gets_one_reminder_and_the_model_restores(loop, server):
    script = [*_yield_script(), text("We can go on now."),
              calls(tool_call("run_center_lane", {"v_ref": 15}, "c2")), text("Back to normal.")]
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, ON) as agent:
        first = agent.deliver(YIELD).result(30)
        second = agent.deliver(GONE).result(30)
    assert first.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]  # no reminder after a call
    assert len(agent.transcript.events("restore_reminder")) == 1
    assert second.applied_calls == [{"tool": "run_center_lane", "arguments": {"v_ref": 15}}]
    assert second.ended == "idle" and second.text == "Back to normal."
    assert loop.slot.current.get("path_tracking").lane == "center"
    # the model saw the note right after the passenger's message: its answer without a call was set aside
    reminded = llm.requests[3]["messages"]
    assert [m["role"] for m in reminded[-2:]] == ["user", "user"]
    assert reminded[-2]["content"].endswith(GONE)
    assert reminded[-1]["content"].startswith("Note from the agent, not the passenger")
    assert all(m.content != "We can go on now." for m in agent.history.messages)
    assert "path_tracking: lane=left (initially center), v_ref_mps=0 (initially 15)" in reminded[-1]["content"]
    note = [m for m in agent.history.messages if m.source == "agent"]
    assert len(note) == 1 and note[0].role == "user"
    [record] = agent.transcript.events("restore_reminder")
    assert record["changes"] == ["path_tracking: lane=left (initially center), v_ref_mps=0 (initially 15)"]
    assert record["withheld_answer"] == "We can go on now."


def test_the_reminder_comes_once_per_step_and_a_second_reply_ends_it(loop, server):
    script = [*_yield_script(), text("Not yet."), text("It is still behind us.")]
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, ON) as agent:
        agent.deliver(YIELD).result(30)
        report = agent.deliver("Wait, it hasn't passed yet.").result(30)
    assert report.applied_calls == [] and report.ended == "idle" and report.text == "It is still behind us."
    assert len(llm.requests) == 4 and len(agent.transcript.events("restore_reminder")) == 1
    assert [m.content for m in agent.history.messages if m.role == "assistant"][-1] == "It is still behind us."
    assert "Not yet." not in [m.content for m in agent.history.messages]
    assert loop.slot.current.get("path_tracking").lane == "left"


def test_no_reminder_from_the_initial_specification_nor_by_default_nor_on_the_last_round(loop, server):
    with ScriptedLLM([text("Hello.")]) as llm, Agent(backend(llm), server, ON) as agent:
        agent.deliver("Hi there.").result(30)
    assert len(llm.requests) == 1 and agent.transcript.events("restore_reminder") == []
    for config in (AgentConfig(), AgentConfig(restore_reminder=True, max_rounds_per_step=1)):  # off by default
        with ScriptedLLM([*_yield_script(), text("Fine.")]) as llm, Agent(backend(llm), server, config) as agent:
            agent.deliver(YIELD).result(30)
            agent.deliver(GONE).result(30)
        assert agent.transcript.events("restore_reminder") == []


def test_the_rules_backend_gets_no_reminder(loop, server):
    with Agent(RulesBackend(), server, ON) as agent:
        agent.deliver(YIELD).result(10)
        report = agent.deliver("What a nice day.").result(10)
    assert report.applied_calls == [] and agent.transcript.events("restore_reminder") == []
    assert not any(m.source == "agent" for m in agent.history.messages)


def test_in_json_schema_mode_the_note_follows_the_models_reply_and_the_restoring_call_is_read(loop, server):
    answers = ['{"name": "run_left_lane", "arguments": {"v_ref": 0}}', '{"reply": "Pulling over."}',
               '{"reply": "We can go on."}', '{"name": "run_center_lane", "arguments": {"v_ref": 15}}',
               '{"reply": "Back to normal."}']
    structured = OpenAISettings(base_url="", model="scripted", api_key_env=None, tool_mode="json_schema",
                                confirmation="model")
    with ScriptedLLM([text(a) for a in answers]) as llm:
        config = structured.model_copy(update={"base_url": llm.base_url})
        with Agent(OpenAIBackend(config), server, ON) as agent:
            agent.deliver(YIELD).result(30)
            report = agent.deliver(GONE).result(30)
    assert report.applied_calls == [{"tool": "run_center_lane", "arguments": {"v_ref": 15}}]
    reminded = llm.requests[3]["messages"]
    assert [m["role"] for m in reminded[-2:]] == ["user", "user"]
    assert reminded[-1]["content"].startswith("Note from the agent")
    assert "response_format" in llm.requests[3]
