"""Bad input: clear errors in the transcript and the log, and the car keeps its last valid specification."""

from __future__ import annotations

import json
import logging
import math

import pytest

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.base import BackendReply
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.messages import ToolCall


class ScriptedBackend:
    """A backend object answering from a list (tests the agent's own checks, for any backend)."""

    name = "scripted"

    def __init__(self, replies):
        self.replies = list(replies)

    async def complete(self, history, tools):
        reply = self.replies.pop(0) if self.replies else BackendReply("ok")
        if isinstance(reply, Exception):
            raise reply
        return reply

    async def aclose(self):
        pass


@pytest.mark.parametrize(
    ("message", "error"),
    [
        ("", "empty message"),
        ("   \n\t ", "empty message"),
        ("go left " * 200_000, "message of 1600000 characters exceeds the limit of 4000"),
        (None, "a message must be text, got NoneType"),
        (42, "a message must be text, got int"),
    ],
)
def test_rejected_messages_never_become_a_step(loop, server, tmp_path, caplog, message, error):
    config = AgentConfig(transcript_path=tmp_path / "t.jsonl")
    with caplog.at_level(logging.WARNING, logger="agentic_mpc.agent"), Agent(RulesBackend(), server, config) as agent:
        report = agent.deliver(message).result(5)
        loop.step()
    assert report.ended == "rejected" and report.errors == [error]
    assert len(agent.history) == 1  # only the system message
    (record,) = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()
                 if json.loads(line)["event"] == "rejected_input"]
    assert record["error"] == error and len(record["preview"]) <= 200
    assert any(error in r.getMessage() for r in caplog.records)
    assert loop.slot.version == 0 and loop.world.time_s > 0


def test_nan_speeds_and_wrong_types_from_a_backend_are_refused_before_the_server(loop, server, caplog):
    replies = [
        BackendReply("", (ToolCall("1", "set_reference_speed", {"v_ref": math.nan}, "{}"),)),
        BackendReply("", (ToolCall("2", "set_reference_speed", {"v_ref": math.inf}, "{}"),)),
        BackendReply("", (ToolCall("3", "run_left_lane", {"v_ref": [1, 2]}, "{}"),)),
        BackendReply("", (ToolCall("4", "teleport", {"x": 1}, "{}"),)),
        BackendReply("I give up."),
    ]
    config = AgentConfig(max_consecutive_errors=10)
    with caplog.at_level(logging.WARNING, logger="agentic_mpc.agent"):
        agent = Agent(ScriptedBackend(replies), server, config)
        with agent:
            report = agent.deliver("do something odd").result(10)
    errors = [c["error"] for c in report.tool_calls]
    assert "v_ref is not a finite number" in errors[0] and "v_ref is not a finite number" in errors[1]
    assert "is not of type 'number'" in errors[2]
    assert "unknown tool 'teleport'" in errors[3]
    assert report.ended == "idle" and loop.slot.version == 0
    assert sum("refused" in r.getMessage() for r in caplog.records) == 4
    results = agent.transcript.events("tool_result")
    assert [r["is_error"] for r in results] == [True] * 4
    # the transcript stays strict JSON even with NaN arguments
    json.dumps(agent.transcript.records, allow_nan=False)


def test_a_crashing_backend_is_an_error_not_a_dead_agent(loop, server):
    replies = [RuntimeError("segfault in the tokenizer")] * 3 + [
        BackendReply("", (ToolCall.of("1", "run_right_lane", {"v_ref": 10}),)),
        BackendReply("done"),
    ]
    config = AgentConfig(backend_attempts=3, retry_backoff_s=0.0)
    with Agent(ScriptedBackend(replies), server, config) as agent:
        failed = agent.deliver("first").result(10)
        worked = agent.deliver("second").result(10)  # the agent is still alive
    assert failed.ended == "backend_error" and "segfault in the tokenizer" in failed.errors[0]
    assert worked.applied_calls == [{"tool": "run_right_lane", "arguments": {"v_ref": 10}}]
    assert len(agent.transcript.events("backend_error")) == 3


def test_too_many_calls_in_one_answer_are_cut(loop, server):
    many = tuple(ToolCall.of(str(i), "set_reference_speed", {"v_ref": i}) for i in range(12))
    config = AgentConfig(max_tool_calls_per_round=8)
    with Agent(ScriptedBackend([BackendReply("", many)]), server, config) as agent:
        report = agent.deliver("flood").result(10)
    assert len(report.applied_calls) == 8
    assert all("too many tool calls" in c["error"] for c in report.tool_calls[8:])
    assert loop.slot.current.get("path_tracking").v_ref_mps == 7.0


def test_lockstep_needs_a_sim_time(loop, server):
    with Agent(RulesBackend(), server, AgentConfig(mode="lockstep")) as agent:
        with pytest.raises(ValueError, match="sim time"):
            agent.deliver("go 10 m/s")


def test_an_agent_without_a_server_fails_to_start_with_a_clear_error():
    from mcp import StdioServerParameters

    from agentic_mpc.agent import AgentError

    missing = StdioServerParameters(command="/nonexistent/agentic-mpc", args=["serve"])
    with pytest.raises(AgentError, match="could not start"):
        Agent(RulesBackend(), missing, AgentConfig(startup_timeout_s=20)).start()
