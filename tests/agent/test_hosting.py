"""The agent as an MCP host of several servers: the knowledge server's tool beside the controller's,
namespaced; its calls change no specification; a server that does not start is left out with the reason."""

from __future__ import annotations

import sys

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import McpServerSettings, OpenAISettings
from agentic_mpc.knowledge.server import build_knowledge_server
from agentic_mpc.knowledge.store import KnowledgeBase
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call


def backend(llm: ScriptedLLM) -> OpenAIBackend:
    return OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="test", api_key_env=None))


def test_a_knowledge_search_is_answered_with_citations_and_changes_nothing(loop, server):
    script = [calls(tool_call("knowledge__search_knowledge", {"query": "rescue lane Germany", "k": 1}, "c1")),
              text("In Germany the rescue lane goes between the left-most lane and the next (StVO 11).")]
    before = loop.slot.current
    with ScriptedLLM(script) as llm, Agent(backend(llm), server,
                                          other_servers={"knowledge": build_knowledge_server(KnowledgeBase())}) as agent:
        names = [t.name for t in agent.tools]
        report = agent.deliver("How do we make way for an ambulance in Germany?").result(30)
        second = llm.requests[1]
    assert "knowledge__search_knowledge" in names and "run_left_lane" in names
    assert report.ended == "idle" and not report.errors
    answer = [m for m in second["messages"] if m["role"] == "tool"][0]["content"]
    assert "de-traffic-rules" in answer and "StVO" in answer
    assert loop.slot.current is before and loop.slot.version == 0


def test_a_server_that_does_not_start_is_left_out_and_the_agent_goes_on(loop, server, tmp_path):
    broken = McpServerSettings(name="docs", command=(sys.executable, "-c", "raise SystemExit(3)"))
    config = AgentConfig(mcp_servers=(broken,), transcript_path=tmp_path / "t.jsonl")
    script = [calls(tool_call("run_left_lane", {"v_ref": 0}, "c1")), text("Pulled over.")]
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, config) as agent:
        assert not any(t.name.startswith("docs__") for t in agent.tools)
        report = agent.deliver("Pull over to the left, please.").result(30)
    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert "MCP server 'docs' left out" in (tmp_path / "t.jsonl").read_text()


def test_server_settings_are_checked():
    import pytest
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="exactly one of command"):
        McpServerSettings(name="docs")
    with pytest.raises(ValidationError, match="'__'"):
        McpServerSettings(name="my__docs", url="http://127.0.0.1:9/mcp")


def test_a_run_with_knowledge_on_gives_its_agent_the_knowledge_server():
    from agentic_mpc.run.loop import AgentSetup
    from tests.agent.conftest import paper_start_config, plain_loop

    with ScriptedLLM([text("Fine.")]) as llm:
        setup = AgentSetup(backend(llm), AgentConfig(knowledge=True))
        with plain_loop(paper_start_config(), agent=setup) as loop:
            assert "knowledge__search_knowledge" in [t.name for t in loop.agent.tools]
