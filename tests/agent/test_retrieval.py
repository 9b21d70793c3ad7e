"""Knowledge brought to the model (agent/retrieval.py): the passages that bear on the message and the
situation go into its context with the document ids to cite, the reply's schema names them, and the search
tool stays offered. The real knowledge server (in process, hosted by the agent), the real MCP server."""

from __future__ import annotations

import asyncio

import pytest
from mcp import Client

from agentic_mpc.agent import Agent
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.retrieval import emergency_needs_way, law_limit, named_place, retrieve, wants_knowledge
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.knowledge.server import build_knowledge_server
from agentic_mpc.knowledge.store import KnowledgeBase
from tests.agent.scripted_llm import ScriptedLLM, text


def knowledge() -> dict:
    return {"knowledge": build_knowledge_server(KnowledgeBase())}


def test_the_passage_is_in_the_context_cited_and_the_reply_must_name_it(server):
    script = [text('{"reply": "100 km/h on an expressway without signs.", "cite": "jp-traffic-rules"}')]
    backend = OpenAIBackend(OpenAISettings(base_url="", api_key_env=None, tool_mode="json_schema"))
    with ScriptedLLM(script) as llm:
        backend.config = backend.config.model_copy(update={"base_url": llm.base_url})
        with Agent(backend, server, other_servers=knowledge()) as agent:
            report = agent.deliver("What is the speed limit on a Japanese expressway?").result(30)
    request = llm.requests[0]
    user = request["messages"][-1]["content"]
    assert "- [jp-traffic-rules] Speed limits by road type: Expressways (national expressways) without signs: " \
           "100 km/h (27.8 m/s)" in user
    assert user.index("[jp-traffic-rules]") < user.index("Passenger: What is the speed limit")
    reply = request["response_format"]["json_schema"]["schema"]["oneOf"][-1]
    assert reply["properties"]["cite"] == {"type": "string", "enum": ["jp-traffic-rules"]}
    assert reply["required"] == ["reply", "cite"]
    assert report.text == "100 km/h on an expressway without signs. [jp-traffic-rules]" and report.tool_calls == []
    recorded = next(m for m in agent.history.messages if m.role == "user")
    assert recorded.data["retrieved"] == ["jp-traffic-rules"] and "[jp-traffic-rules]" in recorded.context
    # a question with its passage is answered: no tool is offered, not even the search (Qwen 1.5B searched
    # again and again beside the passage); without a passage the search stays for what retrieval missed
    names = [o["properties"]["name"]["const"] for o in request["response_format"]["json_schema"]["schema"]["oneOf"]
             if "name" in o["properties"]]
    assert names == []


def test_a_search_the_model_makes_anyway_is_read_back_in_a_few_lines(server):
    script = [text('{"name": "knowledge__search_knowledge", "arguments": {"query": "UK two second gap"}}'),
              text('{"reply": "Two seconds.", "cite": "uk-traffic-rules"}')]
    backend = OpenAIBackend(OpenAISettings(base_url="", api_key_env=None, tool_mode="json_schema"))
    with ScriptedLLM(script) as llm:
        backend.config = backend.config.model_copy(update={"base_url": llm.base_url})
        with Agent(backend, server, other_servers=knowledge()) as agent:
            report = agent.deliver("How many seconds of gap does the UK Highway Code ask for?").result(30)
    result = llm.requests[1]["messages"][-1]["content"]
    assert result.startswith("[result of knowledge__search_knowledge] - [uk-traffic-rules] Following distance: ")
    assert len(result) < 1200 and '"sources"' not in result  # not the search's whole JSON answer
    full = next(m for m in agent.history.messages if m.role == "tool")
    assert '"sources"' in full.content  # the agent's history and transcript keep it whole
    assert report.text == "Two seconds. [uk-traffic-rules]"


def test_nothing_is_retrieved_for_a_message_that_asks_no_rule(server):
    backend = OpenAIBackend(OpenAISettings(base_url="", api_key_env=None, tool_mode="json_schema"))
    with ScriptedLLM([text('{"reply": "OK."}')]) as llm:
        backend.config = backend.config.model_copy(update={"base_url": llm.base_url})
        with Agent(backend, server, other_servers=knowledge()) as agent:
            agent.deliver("Evade obstacles to the left.").result(30)
    request = llm.requests[0]
    assert "[" not in request["messages"][-1]["content"].split("Passenger:")[0]
    options = request["response_format"]["json_schema"]["schema"]["oneOf"]
    assert "cite" not in options[-1]["properties"]
    # nothing retrieved: the search tool is offered, with its query only
    search = next(o for o in options if o["properties"].get("name", {}).get("const") == "knowledge__search_knowledge")
    assert list(search["properties"]["arguments"]["properties"]) == ["query"]


def test_the_rules_backend_gets_no_retrieved_context(server):
    with Agent(RulesBackend(yield_lane="right"), server, other_servers=knowledge()) as agent:
        agent.deliver("What is the speed limit on a Japanese expressway?").result(30)
    user = next(m for m in agent.history.messages if m.role == "user")
    assert user.context is None and not (user.data or {}).get("retrieved")


@pytest.mark.parametrize("message, road, document, section", [
    ("There's an ambulance with its siren on behind us, make way.", {"jurisdiction": "DE"}, "de-traffic-rules",
     "Making way for an emergency vehicle: the rescue lane (Rettungsgasse)"),
    ("Drive at 120 km/h, please.", {"jurisdiction": "JP", "road_type": "motorway"}, "jp-traffic-rules",
     "Speed limits by road type"),
    ("What is the national speed limit on a British motorway?", {"jurisdiction": "DE"}, "uk-traffic-rules",
     "Speed limits by road type (cars, national speed limits)"),
    ("How heavy is the Patrol?", {"jurisdiction": "US-CA"}, "nissan-patrol-manual", "The car"),
])
def test_retrieval_follows_the_place_named_or_the_roads_jurisdiction(message, road, document, section):
    async def run():
        async with Client(build_knowledge_server(KnowledgeBase())) as client:
            async def search(tool, arguments):
                return (await client.call_tool(tool, arguments)).content[0].text
            return await retrieve(search, "search_knowledge", message, road)
    found = asyncio.run(run())
    assert [(f.document, f.section) for f in found] == [(document, section)]
    assert 0 < len(found[0].text) <= 3 * 240 + 2


def test_what_needs_knowledge():
    assert named_place("Is passing on the right allowed in California?") == "US-CA"
    assert named_place("Avoid obstacles on the left.") is None
    assert wants_knowledge("Ambulance behind us!") and wants_knowledge("How long is this car?")
    assert not wants_knowledge("Evade obstacles to the left.")
    assert not wants_knowledge("Hmm.")


def test_an_emergency_vehicle_in_the_situation_brings_the_rule_for_making_way_to_a_message_of_no_topic():
    situation = "Current situation:\n- emergency vehicle ambulance 'amb0' 60 m behind us, in the center lane"

    async def run(message):
        async with Client(build_knowledge_server(KnowledgeBase())) as client:
            async def search(tool, arguments):
                return (await client.call_tool(tool, arguments)).content[0].text
            return await retrieve(search, "search_knowledge", message, {"jurisdiction": "JP"}, situation)
    assert [(f.document, f.section) for f in asyncio.run(run("How long is this car?"))] == [
        ("nissan-patrol-manual", "The car")]
    assert [f.section for f in asyncio.run(run("Hmm."))] == ["Making way for an emergency vehicle"]


def test_the_rule_for_making_way_is_left_out_once_no_emergency_vehicle_needs_way():
    """"The ambulance is gone" beside the rule for making way was answered "No need to change." (Qwen 1.5B,
    Scenario 2): the rule bears on an emergency vehicle that needs way, not on one ahead of us."""
    behind = "Current situation:\n- emergency vehicle ambulance 'amb0' 60 m behind us, in the center lane"
    past = ("Current situation:\n- emergency vehicle ambulance 'amb0' 41 m ahead of us (past us: it needs no way "
            "from us), in the center lane")
    assert emergency_needs_way(behind) is True and emergency_needs_way(past) is False
    assert emergency_needs_way("Current situation:\n- no emergency vehicle around") is False
    assert emergency_needs_way(None) is None

    async def run(message, situation):
        async with Client(build_knowledge_server(KnowledgeBase())) as client:
            async def search(tool, arguments):
                return (await client.call_tool(tool, arguments)).content[0].text
            return await retrieve(search, "search_knowledge", message, {"jurisdiction": "JP"}, situation)
    assert [f.section for f in asyncio.run(run("Thank you. The ambulance is gone.", behind))] == [
        "Making way for an emergency vehicle"]
    assert asyncio.run(run("Thank you. The ambulance is gone.", past)) == []
    assert asyncio.run(run("Hmm.", past)) == []
    # a question still gets its passage
    assert [f.section for f in asyncio.run(run("What must we do for an ambulance?", past))] == [
        "Making way for an emergency vehicle"]


def test_the_laws_limit_on_a_motorway_is_looked_up_said_and_kept_to_by_the_tool_layer():
    """Qwen 1.5B set the road's 31.29 m/s for "120 km/h" on a Japanese motorway with the passage saying 100
    km/h beside it: the law's limit for the road's type is found as the rules find it and the tool layer caps."""
    from agentic_mpc.agent.backends.base import ToolSpec
    from agentic_mpc.agent.messages import ToolCall
    from agentic_mpc.agent.toolset import converted

    async def run(road):
        async with Client(build_knowledge_server(KnowledgeBase())) as client:
            async def search(tool, arguments):
                return (await client.call_tool(tool, arguments)).content[0].text
            return await law_limit(search, "search_knowledge", road)
    mps, line, document = asyncio.run(run({"jurisdiction": "JP", "road_type": "motorway"}))
    assert (mps, document) == (27.8, "jp-traffic-rules") and "100 km/h" in line
    assert asyncio.run(run({"jurisdiction": "US-CA", "road_type": "motorway"}))[0] == 29.1
    assert asyncio.run(run({"jurisdiction": "JP"})) is None  # a road without a type: its signed limit is all
    speed = ToolSpec("set_reference_speed", "", {"type": "object", "properties": {
        "v_ref": {"type": "number", "minimum": 0, "maximum": 31.29}}, "required": ["v_ref"]})
    call, note = converted(ToolCall("c", "set_reference_speed", {"v_ref": 120, "unit": "km/h"}), [speed],
                           (27.8, "a motorway in JP [jp-traffic-rules]"))
    assert call.arguments == {"v_ref": 27.8} and "the law's limit here (a motorway in JP [jp-traffic-rules])" in note
    call, note = converted(ToolCall("c", "set_reference_speed", {"v_ref": 90, "unit": "km/h"}), [speed], (27.8, ""))
    assert call.arguments == {"v_ref": 25} and note is None
    call, _ = converted(ToolCall("c", "set_reference_speed", {"v_ref": 150, "unit": "km/h"}), [speed], (36.1, ""))
    assert call.arguments == {"v_ref": 31.29}  # the road's limit where the law allows more


def test_the_chat_backend_reads_the_laws_limit_of_the_step_being_answered():
    from agentic_mpc.agent.backends.chat import law_limit as limit_of_step
    from agentic_mpc.agent.messages import Message

    earlier = Message("user", "Go 120 km/h.", source="user", data={"law_limit": {"mps": 27.8, "why": "JP"}})
    assert limit_of_step([Message("system", "s"), earlier]) == (27.8, "JP")
    assert limit_of_step([earlier, Message("user", "Hello.", source="user")]) is None  # this step's, not an earlier one's
