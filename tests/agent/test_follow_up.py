"""After a model's calls (agent/backends/follow_up.py): a reply written from the results when the calls made every
kind of change the message asks for, the model asked again, told what is left, when they did not, and asked as
before after a failed call. A real MCP server in process, a real HTTP model server with scripted answers."""

from __future__ import annotations

import pytest

from agentic_mpc.agent import Agent
from agentic_mpc.agent.backends.follow_up import asked_kinds
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import OpenAISettings
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call


def model_at_url(base_url: str, **options) -> OpenAIBackend:
    return OpenAIBackend(OpenAISettings(base_url=base_url, model="m", api_key_env=None, **options))


def model(llm: ScriptedLLM, **options) -> OpenAIBackend:
    return model_at_url(llm.base_url, **options)


@pytest.mark.parametrize("message, kinds", [
    ("Steer around the debris on the right, and bring us down to 12 m/s.",
     {"side": "steer around the debris on the right", "speed": "bring us down to 12 m/s"}),
    ("Get into the left lane, then swerve right around obstacles.",
     {"lane": "get into the left lane", "side": "swerve right around obstacles"}),
    ("Keep a safe distance and go slower.", {"gap": "keep a safe distance", "speed": "go slower"}),
    ("An ambulance is coming behind us. We'd better let them pass.", {}),  # any call of the car does it
    ("Thank you. The ambulance is gone.", {}),
    ("Overtake the car on the left.", {}),  # a side to pass a car on is the overtake's, not the obstacles'
])
def test_the_kinds_of_change_a_message_asks_for(message, kinds):
    assert asked_kinds(message) == kinds


def test_calls_that_did_what_was_asked_get_a_reply_written_from_their_results(server):
    script = [calls(tool_call("set_reference_speed", {"v_ref": 100, "unit": "km/h"}))]
    with ScriptedLLM(script) as llm, Agent(model(llm), server) as agent:
        report = agent.deliver("Go 100 km/h.").result(30)
    assert len(llm.requests) == 1  # one answer of the model: the call
    assert report.applied_calls == [{"tool": "set_reference_speed", "arguments": {"v_ref": 25.0}}]
    # the reply names the call and keeps the tool layer's note about the unit
    assert report.text.startswith("Done: set_reference_speed(v_ref=25") and "km/h" in report.text


def test_a_message_with_two_requests_gets_its_second_call_asked_for_by_name(server):
    script = [calls(tool_call("set_preferred_steering_direction", {"direction": "left"})),
              calls(tool_call("set_reference_speed", {"v_ref": 10, "unit": "m/s"}))]
    with ScriptedLLM(script) as llm, Agent(model(llm, max_tokens=64), server) as agent:
        report = agent.deliver("Avoid obstacles from the left and slow down to 10 m/s.").result(30)
    assert [c["tool"] for c in report.applied_calls] == ["set_preferred_steering_direction", "set_reference_speed"]
    assert len(llm.requests) == 2
    told = str(llm.requests[1]["messages"][-1]["content"])
    assert 'The message also asks for the speed ("slow down to 10 m/s"): make that call now.' in told
    assert report.text.startswith("Done: set_preferred_steering_direction(direction=left); set_reference_speed(")


def test_after_a_refused_call_the_model_answers_the_result_itself(server):
    script = [calls(tool_call("set_following_distance", {"gap": 30})), text("There is no car ahead to follow.")]
    with ScriptedLLM(script) as llm, Agent(model(llm), server) as agent:
        report = agent.deliver("Keep 30 m behind the car ahead.").result(30)
    assert not report.applied_calls and len(llm.requests) == 2
    assert report.text == "There is no car ahead to follow."


def test_confirmation_model_keeps_the_models_own_reply(server):
    script = [calls(tool_call("set_reference_speed", {"v_ref": 12, "unit": "m/s"})), text("Slowing to 12 m/s.")]
    with ScriptedLLM(script) as llm, Agent(model(llm, confirmation="model"), server) as agent:
        report = agent.deliver("Go 12 m/s.").result(30)
    assert len(llm.requests) == 2 and report.text == "Slowing to 12 m/s."


def test_where_a_passage_was_retrieved_the_reply_cites_it(server):
    from agentic_mpc.knowledge.server import build_knowledge_server
    from agentic_mpc.knowledge.store import KnowledgeBase

    script = [text('{"name": "set_reference_speed", "arguments": {"v_ref": 100, "unit": "km/h"}}')]
    backend = model_at_url("", tool_mode="json_schema")
    with ScriptedLLM(script) as llm:
        backend.config = backend.config.model_copy(update={"base_url": llm.base_url})
        with Agent(backend, server, other_servers={"knowledge": build_knowledge_server(KnowledgeBase())}) as agent:
            report = agent.deliver("Drive at the speed limit of a Japanese expressway.").result(30)
    assert len(llm.requests) == 1  # the passage was in the call's context: the reply names it
    assert report.text.startswith("Done: set_reference_speed(v_ref=25") and report.text.endswith("[jp-traffic-rules]")
