"""The ``openai`` backend against a real HTTP server on 127.0.0.1 with scripted answers, malformed ones included."""

from __future__ import annotations

import json
import socket

import pytest

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend, parse_arguments
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.mcp.protocol import ToolName
from tests.agent.scripted_llm import Delay, Raw, ScriptedLLM, calls, text, tool_call

PAPER_ROAD_TOOLS = ["run_center_lane", "run_left_lane", "run_right_lane",  # no emergency lane, no junction there
                    *(str(name) for name in ToolName if name not in (
                        ToolName.PULL_OVER, ToolName.TURN_AT_NEXT_JUNCTION, ToolName.DRIVE_TO))]
PAPER_2A = "An ambulance is coming behind us. We'd better let them pass."


def backend(llm: ScriptedLLM, **options) -> OpenAIBackend:
    """The backend with the full prompt (every tool, its whole description), whose requests these tests read;
    the compact one's are tests/agent/test_compact_prompt.py's."""
    options.setdefault("prompt", "full")
    return OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="granite-test", api_key_env=None, **options))


def test_a_well_behaved_model_gives_validated_calls_and_sees_their_results(loop, server):
    script = [calls(tool_call("run_left_lane", {"v_ref": 0}, "c1"), content="Pulling over."), text("Done.")]
    with ScriptedLLM(script) as llm, Agent(backend(llm), server) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert report.text == "Done." and report.ended == "idle"
    assert loop.slot.current.get("path_tracking").lane == "left"
    first, second = llm.requests
    assert first["model"] == "granite-test" and first["tool_choice"] == "auto"
    functions = {t["function"]["name"]: t["function"] for t in first["tools"]}
    assert set(functions) == set(PAPER_ROAD_TOOLS)
    v_ref = functions["run_left_lane"]["parameters"]["properties"]["v_ref"]
    assert (v_ref["minimum"], v_ref["maximum"]) == (0.0, 25.0) and "title" not in v_ref
    assert [m["role"] for m in first["messages"]] == ["system", "user"]
    assert "Initially attached primitives" in first["messages"][0]["content"]
    # the second request carries the agent's call and the tool result
    assert [m["role"] for m in second["messages"]] == ["system", "user", "assistant", "tool"]
    assert second["messages"][2]["tool_calls"][0]["function"] == {"name": "run_left_lane", "arguments": '{"v_ref": 0}'}
    assert second["messages"][3]["tool_call_id"] == "c1"
    # the model reads the result in one line: what applied and how it differs from the initial specification
    assert second["messages"][3]["content"] == (
        "run_left_lane(v_ref=0) applied; differences from the initial specification: path_tracking: lane=left "
        "(initially center), v_ref_mps=0 (initially 15).")
    (warm_up,) = llm.warmups  # the system message was read before the message came, with the same tools
    assert warm_up["messages"] == first["messages"][:1] and warm_up["tools"] == first["tools"]


MALFORMED = [
    (tool_call("fly_to_the_moon", {"v_ref": 1}), "unknown tool 'fly_to_the_moon'"),
    (tool_call("run_left_lane", '{"v_ref": 0'), "not valid JSON"),
    (tool_call("run_left_lane", '{"v_ref": NaN}'), "NaN is not a valid JSON number"),
    (tool_call("run_left_lane", '[0]'), "must be a JSON object"),
    (tool_call("run_left_lane", {"v_ref": 99}), "greater than the maximum"),
    (tool_call("run_left_lane", {"v_ref": -3}), "less than the minimum"),
    (tool_call("set_reference_speed", {"v_ref": "fast"}), "is not of type 'number'"),
    (tool_call("run_right_lane", {"speed": 10}), "'v_ref' is a required property"),
    (tool_call("set_preferred_steering_direction", {"direction": "up"}), "is not one of"),
    ({"id": "x", "type": "function", "function": {"arguments": "{}"}}, "without a function name"),
]


def test_every_malformed_answer_becomes_a_tool_error_for_the_model_and_changes_nothing(loop, server):
    script = [calls(call) for call, _ in MALFORMED]
    script += [calls(tool_call("run_left_lane", {"v_ref": 0})), text("Done at last.")]
    config = AgentConfig(max_rounds_per_step=len(script) + 1, max_consecutive_errors=len(MALFORMED) + 1)
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver(PAPER_2A).result(60)
    assert report.ended == "idle" and report.text == "Done at last."
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert loop.slot.version == 1  # only the valid call reached the controller
    errors = [c["error"] for c in report.tool_calls if not c["ok"]]
    for (_, expected), error in zip(MALFORMED, errors, strict=True):
        assert expected in error
    # each error went back to the model as a tool message answering its call
    last_request = llm.requests[len(MALFORMED)]["messages"]
    tool_messages = [m for m in last_request if m["role"] == "tool"]
    assert len(tool_messages) == len(MALFORMED)
    assert all(m["content"].startswith("Error: ") for m in tool_messages)
    assert tool_messages[0]["content"].endswith(f"available tools: {', '.join(sorted(PAPER_ROAD_TOOLS))}")
    # malformed arguments are echoed as {} so strict servers accept the history
    echoed = [m for m in last_request if m["role"] == "assistant"][1]["tool_calls"][0]["function"]["arguments"]
    assert echoed == "{}"
    transcript_errors = [r for r in agent.transcript.records if r["event"] == "tool_result" and r["is_error"]]
    assert len(transcript_errors) == len(MALFORMED)


def test_a_model_that_never_gets_it_right_is_stopped_after_bounded_retries(loop, server):
    script = [calls(tool_call("run_left_lane", {"v_ref": 1000}))] * 10
    config = AgentConfig(max_consecutive_errors=3)
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.ended == "gave_up" and len(llm.requests) == 3
    assert loop.slot.version == 0 and report.applied_calls == []


@pytest.mark.parametrize(
    "failure",
    [
        Raw(500, '{"error": "model crashed"}'),
        Raw(200, "this is not json"),
        Raw(200, '{"choices": []}'),
        Raw(200, '{"choices": [{"message": "hello"}]}'),
        Delay(3.0, text("too late")),
    ],
    ids=["http-500", "not-json", "no-choices", "message-not-object", "timeout"],
)
def test_transport_failures_are_retried(loop, server, failure):
    script = [failure, calls(tool_call("set_preferred_steering_direction", {"direction": "left"})), text("ok")]
    config = AgentConfig(backend_attempts=3, retry_backoff_s=0.0)
    with ScriptedLLM(script) as llm, Agent(backend(llm, timeout_s=1.0), server, config) as agent:
        report = agent.deliver("Let's pass obstacles on the left.").result(30)
    assert report.applied_calls == [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "left"}}]
    (error,) = agent.transcript.events("backend_error")
    assert error["attempt"] == 1 and error["backend"] == "openai" and error["error"]


def test_an_unreachable_backend_ends_the_step_with_a_clear_error_and_the_car_keeps_driving(loop, server, tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nothing listens there once the socket is closed
    dead = OpenAIBackend(OpenAISettings(base_url=f"http://127.0.0.1:{port}/v1", api_key_env=None, timeout_s=2.0))
    config = AgentConfig(backend_attempts=2, retry_backoff_s=0.0, transcript_path=tmp_path / "t.jsonl")
    with Agent(dead, server, config) as agent:
        future = agent.deliver(PAPER_2A)
        for _ in range(25):  # the car drives on while the agent fails
            loop.step()
        report = future.result(30)
    assert report.ended == "backend_error" and "cannot reach" in report.errors[0]
    assert "after 2 attempts" in report.errors[0]
    assert loop.slot.version == 0 and loop.world.time_s == pytest.approx(1.0)
    assert loop.world.ego_state[3] > 14.0
    lines = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    assert [r["attempt"] for r in lines if r["event"] == "backend_error"] == [1, 2]
    assert lines[-1]["event"] == "step_end" and lines[-1]["ended"] == "backend_error"


def test_tool_calls_written_as_text_are_understood(loop, server):
    content = 'Sure.\n<tool_call>\n{"name": "run_left_lane", "arguments": {"v_ref": 0}}\n</tool_call>'
    with ScriptedLLM([{"role": "assistant", "content": content}, text("Done.")]) as llm:
        with Agent(backend(llm), server) as agent:
            report = agent.deliver(PAPER_2A).result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]


def test_the_api_key_is_sent_from_the_named_environment_variable(monkeypatch, loop, server):
    monkeypatch.setenv("AGENTIC_TEST_KEY", "sk-test-123")
    with ScriptedLLM([text("hello")]) as llm:
        keyed = OpenAIBackend(OpenAISettings(base_url=llm.base_url, api_key_env="AGENTIC_TEST_KEY"))
        with Agent(keyed, server) as agent:
            report = agent.deliver("Hello!").result(30)
    assert llm.headers[0]["Authorization"] == "Bearer sk-test-123"
    assert report.text == "hello" and report.applied_calls == []


def test_parse_arguments():
    assert parse_arguments('{"v_ref": 3}') == ({"v_ref": 3}, None)
    assert parse_arguments({"v_ref": 3}) == ({"v_ref": 3}, None)
    assert parse_arguments("") == ({}, None)
    assert parse_arguments('{"v_ref": Infinity}')[1].startswith("arguments are not valid JSON")
    assert parse_arguments(42)[1] == "arguments must be a JSON object, got int"


FENCED = '```json\n{"name": "run_left_lane", "arguments": {"v_ref": 0}}\n```'


@pytest.mark.parametrize("content", [FENCED, '{{"name": "run_left_lane", "arguments": {{"v_ref": 0}}}}'],
                         ids=["fenced", "doubled-braces"])
def test_calls_written_in_fences_or_doubled_braces_are_applied(loop, server, content):
    with ScriptedLLM([text(content), text("Done.")]) as llm, Agent(backend(llm), server) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert report.ended == "idle" and not report.errors
    # the model sees its call as it wrote it (not as tool_calls its template may drop) and the result as text
    sent = llm.requests[1]["messages"]
    assert sent[2] == {"role": "assistant", "content": '{"name": "run_left_lane", "arguments": {"v_ref": 0}}'}
    assert sent[3]["role"] == "user" and sent[3]["content"].startswith("[result of run_left_lane] ")


def test_a_failed_call_in_text_is_an_error_the_model_is_told_about_and_can_fix(loop, server, tmp_path):
    broken = '```json\n{"name": "run_left_lane", "arguments": {"v_ref": 0\n```'
    script = [text(broken), text(FENCED), text("Done.")]
    config = AgentConfig(transcript_path=tmp_path / "t.jsonl")
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert report.ended == "idle" and len(report.errors) == 1
    assert report.errors[0].startswith("unparsed_tool_call: Error: could not read the tool call")
    told = llm.requests[1]["messages"][-1]
    assert told["role"] == "user" and '{"name": "<tool>", "arguments": {...}}' in told["content"]
    assert "run_center_lane, run_left_lane, run_right_lane" in told["content"]
    records = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    failed = [r for r in records if r["event"] == "tool_result" and r["is_error"]]
    assert len(failed) == 1 and "could not read the tool call" in failed[0]["error"]
    assert next(r for r in records if r["event"] == "tool_call")["raw_arguments"].startswith('{"name": "run_left_lane"')
    assert records[-1]["event"] == "step_end" and records[-1]["errors"] == report.errors


def test_a_model_that_keeps_writing_unreadable_calls_gives_up_and_changes_nothing(loop, server):
    script = [text('{"name": "run_left_lane", "arguments": {"v_ref": ')] * 10
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, AgentConfig(max_consecutive_errors=3)) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.ended == "gave_up" and len(llm.requests) == 3 and len(report.errors) == 3
    assert loop.slot.version == 0


def test_an_endless_loop_of_calls_is_bounded(loop, server):
    # every round a different call (the same one again would end the step as "repeated")
    script = [text(f'```json\n{{"name": "run_left_lane", "arguments": {{"v_ref": {v}}}}}\n```') for v in range(20)]
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, AgentConfig(max_rounds_per_step=4)) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.ended == "round_limit" and len(llm.requests) == 4 and len(report.applied_calls) == 4
    with ScriptedLLM([text(FENCED)] * 20) as llm, Agent(backend(llm), server) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.ended == "repeated" and len(llm.requests) == 2 and len(report.applied_calls) == 1


def test_prose_is_a_reply_without_a_call_and_without_an_error(loop, server):
    with ScriptedLLM([text("What a lovely day indeed.")]) as llm, Agent(backend(llm), server) as agent:
        report = agent.deliver("What a nice day!").result(30)
    assert report.ended == "idle" and report.text == "What a lovely day indeed." and not report.errors


def test_json_schema_mode_through_the_agent(loop, server):
    script = [text('{"name": "run_left_lane", "arguments": {"v_ref": 0}}'), text('{"reply": "Pulled over."}')]
    with ScriptedLLM(script) as llm, Agent(backend(llm, tool_mode="json_schema"), server) as agent:
        report = agent.deliver(PAPER_2A).result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert report.text == "Pulled over." and report.ended == "idle"
    first, second = llm.requests
    assert "tools" not in first and first["response_format"]["type"] == "json_schema"
    names = [o["properties"]["name"]["const"] for o in first["response_format"]["json_schema"]["schema"]["oneOf"][:-1]]
    assert "run_left_lane" in names and len(names) == len(PAPER_ROAD_TOOLS)
    assert [m["role"] for m in second["messages"]] == ["system", "user", "assistant", "user"]


def test_a_model_that_repeats_its_call_ends_the_step_without_running_it_again(loop, server):
    repeat = calls(tool_call("set_reference_speed", {"v_ref": 10}, "c1"))
    script = [repeat, calls(tool_call("set_reference_speed", {"v_ref": 10}, "c2")), text("never asked")]
    with ScriptedLLM(script) as llm, Agent(backend(llm), server) as agent:
        report = agent.deliver("Please slow down to 36 km/h.").result(30)
    assert report.ended == "repeated" and len(llm.requests) == 2
    assert report.applied_calls == [{"tool": "set_reference_speed", "arguments": {"v_ref": 10}}]
    assert [r["event"] for r in agent.transcript.records].count("tool_call") == 1
    assert any(r["event"] == "repeated_calls" for r in agent.transcript.records)
