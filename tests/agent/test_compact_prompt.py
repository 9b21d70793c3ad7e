"""The compact prompt a small model can use (agent/compact_prompt.py, agent/toolset.py): the tools of this
road only, one line each, speeds with a unit the tool layer converts; the rules backend's system message and
calls unchanged. Real MCP server in process, a real HTTP model server with scripted answers."""

from __future__ import annotations

import json

import pytest

from agentic_mpc.agent import Agent
from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.backends.rules_first import RulesFirst
from agentic_mpc.agent.messages import ToolCall
from agentic_mpc.agent.prompt import system_prompt
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.agent.toolset import converted, offered
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call

PAPER_TOOLS = ["run_center_lane", "run_left_lane", "run_right_lane", "set_reference_speed",
               "set_preferred_steering_direction", "clear_preferred_steering_direction"]


def model(llm: ScriptedLLM, **options) -> OpenAIBackend:
    return OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="m", api_key_env=None, **options))


def schema_tools(request: dict) -> list[str]:
    options = request["response_format"]["json_schema"]["schema"]["oneOf"]
    return [o["properties"]["name"]["const"] for o in options if "name" in o["properties"]]


def test_the_paper_road_offers_the_paper_tools_in_a_short_cached_system_message(server):
    script = [calls(tool_call("set_preferred_steering_direction", {"direction": "right"})), text("Done.")]
    with ScriptedLLM(script) as llm, Agent(model(llm), server) as agent:
        report = agent.deliver("Avoid obstacles from the right.").result(30)
        tools = agent.tools
    system, first = llm.warmups[0]["messages"][0]["content"], llm.requests[0]
    assert report.applied_calls == [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "right"}}]
    # 13 tools listed by the server, 6 offered: the paper's; the fixed part read once (the warm-up) and
    # the same in every request after it
    assert len(tools) == 13 and [t["function"]["name"] for t in first["tools"]] == PAPER_TOOLS
    assert first["messages"][0]["content"] == system == agent.history.messages[0].content
    full = system_prompt(agent.history.messages[0].data["initial_specification"], tools,
                         road=agent.history.messages[0].data["road"])
    assert len(system) < 2200 and len(full) > 4000  # about 500 tokens against the full prompt's 1,100+
    for line in [("Road: right-hand traffic; lanes from the road edge: right (edge lane), center, left; speed "
                 "limit 25 m/s (90 km/h)."), ("Start (restore it for 'back to normal', 'reset', 'undo'): center lane "
                 "at 15 m/s, no preferred side."), "- run_right_lane(v_ref, unit): drive in the right lane at v_ref",
                 'behind us, or \'make way\', \'pull over\': run_right_lane(v_ref=0, unit="m/s").',
                 'It has passed, is gone, all clear: run_center_lane(v_ref=15, unit="m/s").']:
        assert line in system
    assert "overtake" not in system and "following" not in system
    v_ref = first["tools"][0]["function"]["parameters"]["properties"]
    assert v_ref["unit"]["enum"] == ["m/s", "km/h", "mph"] and "maximum" not in v_ref["v_ref"]


def test_a_message_that_asks_for_another_tool_brings_it_into_that_step(server):
    script = [json.dumps({"name": "set_following_distance", "arguments": {"gap": 20}}), '{"reply": "OK."}']
    with ScriptedLLM([text(s) for s in script]) as llm, Agent(model(llm, tool_mode="json_schema"), server) as agent:
        agent.deliver("Stay 20 m behind the car ahead.").result(30)
        agent.deliver("Evade obstacles on the left.").result(30)
    asked, later = llm.requests[0], llm.requests[-1]
    assert set(schema_tools(asked)) == {*PAPER_TOOLS, "set_following_distance", "change_following_distance",
                                        "clear_following_distance"}
    assert "Also for this message: set_following_distance(gap)" in asked["messages"][-1]["content"]
    assert schema_tools(later) == PAPER_TOOLS and "Also for" not in later["messages"][-1]["content"]
    # the system message does not change with it (the model's cache keeps it)
    assert asked["messages"][0] == later["messages"][0]


def test_the_rules_backend_keeps_the_full_system_message_and_every_tool(server):
    with Agent(RulesBackend(yield_lane="right"), server) as agent:
        report = agent.deliver("Stay 20 m behind the car ahead.").result(30)
        system = agent.history.messages[0].content
    assert "Available tools:" in system and "- overtake(" in system  # what the goldens' events.csv record
    assert report.ended in ("idle", "repeated")


def test_rules_first_gives_the_model_behind_it_the_compact_prompt(server):
    with ScriptedLLM([text('{"reply": "Hi."}')]) as llm, \
            Agent(RulesFirst(RulesBackend(yield_lane="right"), model(llm)), server) as agent:
        agent.deliver("Ein schöner Tag, nicht wahr?").result(30)
    assert agent.history.messages[0].content.startswith("You drive a car for its passenger")


@pytest.mark.parametrize("said, applied", [({"v_ref": 36, "unit": "km/h"}, 10), ({"v_ref": 45, "unit": "mph"}, 20.117),
                                           ({"v_ref": 12, "unit": "m/s"}, 12), ({"v_ref": 150, "unit": "km/h"}, 25)])
def test_the_tool_layer_converts_the_passengers_unit_and_keeps_to_the_limit(server, said, applied):
    script = [calls(tool_call("set_reference_speed", said)), text("Done.")]
    with ScriptedLLM(script) as llm, Agent(model(llm), server) as agent:
        report = agent.deliver("Speed please.").result(30)
    assert report.applied_calls == [{"tool": "set_reference_speed", "arguments": {"v_ref": applied}}]
    assert server.tools.slot.current.get("path_tracking").v_ref_mps == pytest.approx(applied)
    if said["v_ref"] == 150:  # said back: the model's answer carries why it is not 150 km/h
        step = next(m.content for m in agent.history.messages if m.role == "assistant")
        assert "150 km/h is 41.667 m/s, above this road's limit of 25 m/s (90 km/h): set to the limit." in step


def test_a_speed_without_a_unit_above_the_limit_is_still_refused(server):
    script = [calls(tool_call("set_reference_speed", {"v_ref": 99})), text("Sorry.")]
    with ScriptedLLM(script) as llm, Agent(model(llm), server) as agent:
        report = agent.deliver("Faster!").result(30)
    assert report.applied_calls == [] and "maximum" in " ".join(report.errors + [str(report.tool_calls)])


def test_converted_names_a_unit_it_does_not_know_and_leaves_other_calls():
    speed = ToolSpec("set_reference_speed", "", {"type": "object", "properties": {
        "v_ref": {"type": "number", "minimum": 0, "maximum": 25}}, "required": ["v_ref"]})
    side = ToolSpec("set_preferred_steering_direction", "", {"type": "object", "properties": {
        "direction": {"enum": ["left", "right"]}}})
    bad, _ = converted(ToolCall("c", "set_reference_speed", {"v_ref": 3, "unit": "knots"}), [speed])
    assert bad.error and "knots" in bad.error
    same, note = converted(ToolCall("c", "set_preferred_steering_direction", {"direction": "left"}), [side])
    assert same.arguments == {"direction": "left"} and note is None
    assert [t.name for t in offered([speed, side], "all")] == ["set_reference_speed", "set_preferred_steering_direction"]


def test_a_call_written_as_the_text_of_a_structured_reply_is_read_as_the_call():
    from agentic_mpc.agent.backends.call_parsing import calls_from_text

    ids = iter(range(10))
    said = '{"reply": "set_preferred_steering_direction(direction=\\"right\\")"}'
    rest, read = calls_from_text(said, ["set_preferred_steering_direction"], lambda: f"t{next(ids)}", structured=True)
    assert rest == "" and [(c.name, c.arguments) for c in read] == [("set_preferred_steering_direction",
                                                                    {"direction": "right"})]
    rest, read = calls_from_text('{"reply": "Nice day (indeed)."}', ["set_preferred_steering_direction"],
                                 lambda: "t", structured=True)
    assert rest == "Nice day (indeed)." and read == []


def test_a_dialogues_earlier_steps_reach_the_model_in_a_line_each_not_as_its_replies(server):
    script = [calls(tool_call("run_right_lane", {"v_ref": 0, "unit": "m/s"})),
              calls(tool_call("run_center_lane", {"v_ref": 15, "unit": "m/s"}))]  # the replies: from the results
    with ScriptedLLM(script) as llm, Agent(model(llm), server) as agent:
        agent.deliver("Ambulance behind us!").result(30)
        report = agent.deliver("It's gone.").result(30)
    assert report.applied_calls == [{"tool": "run_center_lane", "arguments": {"v_ref": 15}}]
    assert len(llm.requests) == 2 and report.text.startswith("Done: run_center_lane(v_ref=15")
    second = llm.requests[1]["messages"]
    assert [m["role"] for m in second] == ["system", "user"]  # no earlier replies to copy
    assert second[1]["content"].startswith("Earlier in this drive:\n- passenger: Ambulance behind us!\n"
                                           "  you called run_right_lane(v_ref=0)\n\nCurrent situation")
    assert second[1]["content"].endswith("Passenger: It's gone.")
    # the history the agent keeps (and the transcript) is whole
    assert [m.role for m in agent.history.messages].count("assistant") == 4


@pytest.mark.parametrize("message, question", [
    ("What should we do if an ambulance comes?", True),
    ("Which lane are we in?", True),
    ("Could you drive a bit faster, say 20 m/s?", False),
    ("Let's try to avoid obstacles from the right, shall we?", False),
    ("An ambulance is coming behind us. We'd better let them pass.", False),
])
def test_a_question_is_answered_with_a_reply_the_schema_offers_no_call(server, message, question):
    """json_schema: a question's answer cannot be a call to the car (Qwen 1.5B yielded to "what must we do for
    an ambulance?" with one near); a request put as a question keeps its tools."""
    with ScriptedLLM([text('{"reply": "OK."}')]) as llm, Agent(model(llm, tool_mode="json_schema"), server) as agent:
        agent.deliver(message).result(30)
    assert (schema_tools(llm.requests[0]) == []) is question


def test_a_question_without_a_passage_may_search_once_then_it_is_answered(server):
    from agentic_mpc.knowledge.server import build_knowledge_server
    from agentic_mpc.knowledge.store import KnowledgeBase

    script = [text('{"name": "knowledge__search_knowledge", "arguments": {"query": "real person"}}'),
              text('{"reply": "No, a program."}')]
    with ScriptedLLM(script) as llm, Agent(model(llm, tool_mode="json_schema"), server,
                                          other_servers={"knowledge": build_knowledge_server(KnowledgeBase())}) as agent:
        report = agent.deliver("Who sang zorblat?").result(30)
    assert [schema_tools(r) for r in llm.requests] == [["knowledge__search_knowledge"], []]
    assert [c["tool"] for c in report.applied_calls] == ["knowledge__search_knowledge"]  # no call to the car
    assert report.text.startswith("No, a program.")
