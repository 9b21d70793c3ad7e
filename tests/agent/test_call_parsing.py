"""Tool calls written as text, read from answers as real models write them (see ../shared/notes/mcp-and-llm.md:
the Qwen coders behind llama.cpp wrote every call in a Markdown fence or with doubled braces, never as
``tool_calls``), and the structured mode's schema and history."""

from __future__ import annotations

import itertools
import json

import jsonschema
import pytest

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.call_parsing import TEXT_CALL_PREFIX, UNPARSED, calls_from_text, load_json_like
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.agent.backends.structured import (
    REPLY_AFTER_RESULTS_CHARS,
    REPLY_MAX_CHARS,
    STRUCTURED_INSTRUCTION,
    answer_schema,
    render_messages,
)
from agentic_mpc.agent.messages import Message, ToolCall

V_REF = {"type": "number", "minimum": 0.0, "maximum": 25.0, "title": "V Ref", "description": "m/s"}
TOOLS = tuple(
    [ToolSpec(f"run_{lane}_lane", f"Drive on the {lane} lane", {
        "type": "object", "properties": {"v_ref": V_REF}, "required": ["v_ref"], "additionalProperties": False,
        "title": "run_laneArguments"}) for lane in ("center", "left", "right")]
    + [ToolSpec("set_reference_speed", "Change v_ref", {"type": "object", "properties": {"v_ref": V_REF},
                                                        "required": ["v_ref"], "additionalProperties": False}),
       ToolSpec("set_preferred_steering_direction", "Prefer a side", {
           "type": "object", "properties": {"direction": {"type": "string", "enum": ["left", "right"]}},
           "required": ["direction"], "additionalProperties": False}),
       ToolSpec("clear_preferred_steering_direction", "Remove J3", {"type": "object", "properties": {},
                                                                     "additionalProperties": False})]
)
NAMES = [t.name for t in TOOLS]


def read(text: str, structured: bool = False) -> tuple[str, list[ToolCall]]:
    ids = itertools.count(1)
    return calls_from_text(text, NAMES, lambda: f"{TEXT_CALL_PREFIX}{next(ids)}", structured=structured)


def calls_of(text: str) -> list[tuple[str, dict | None]]:
    return [(c.name, c.arguments) for c in read(text)[1]]


LEFT_0 = [("run_left_lane", {"v_ref": 0})]

# What the models wrote (Qwen2.5-Coder 1.5B/0.5B through llama.cpp with its chat template, native tools on)
REAL_ANSWERS = [
    ('```json\n{"name": "run_left_lane", "arguments": {"v_ref": 0}}\n```', LEFT_0),
    ('```json\n{\n  "name": "run_left_lane",\n  "arguments": {\n    "v_ref": 0\n  }\n}\n```', LEFT_0),
    (('To let the ambulance pass, we pull over to the left lane and stop.\n\n```json\n'
      '{"name": "run_left_lane", "arguments": {"v_ref": 0}}\n```'), LEFT_0),
    ('{{"name": "run_left_lane", "arguments": {{"v_ref": 0}}}}', LEFT_0),
    ('{{"name": "set_preferred_steering_direction", "arguments": {"direction": "right"}}}',
     [("set_preferred_steering_direction", {"direction": "right"})]),
    ('```\n{{"name": "run_center_lane", "arguments": {{"v_ref": 15}}}}\n```', [("run_center_lane", {"v_ref": 15})]),
    ('<tool_call>\n{"name": "run_left_lane", "arguments": {"v_ref": 0}}\n</tool_call>', LEFT_0),
    ('{"name": "run_left_lane", "parameters": {"v_ref": 0}}', LEFT_0),
    ('{"name": "run_left_lane", "arguments": "{\\"v_ref\\": 0}"}', LEFT_0),
    ("{'name': 'run_left_lane', 'arguments': {'v_ref': 0}}", LEFT_0),
    ('{"type": "function", "function": {"name": "run_left_lane", "arguments": "{\\"v_ref\\": 0}"}}', LEFT_0),
    ('{"tool_call": {"name": "clear_preferred_steering_direction", "arguments": {}}}',
     [("clear_preferred_steering_direction", {})]),
    ('{"run_left_lane": {"v_ref": 0}}', LEFT_0),
    ("run_left_lane(v_ref=0)", LEFT_0),
    (('[{"name": "run_left_lane", "arguments": {"v_ref": 0}}, {"name": "set_reference_speed", "arguments": '
      '{"v_ref": 5}}]'), [*LEFT_0, ("set_reference_speed", {"v_ref": 5})]),
]


# Verbatim: Qwen2.5-Coder-1.5B-Instruct Q4_K_M through llama.cpp (xllamacpp), native tools, jinja template on
QWEN_1_5B = [
    ('```json\n{\n  "name": "set_preferred_steering_direction",\n  "arguments": {\n    "direction": "right"\n  }\n}\n```',
     [("set_preferred_steering_direction", {"direction": "right"})]),
    ('{{"name": "clear_preferred_steering_direction"}}', [("clear_preferred_steering_direction", {})]),
    ('{{"name": "clear_preferred_steering_direction", "arguments": {}}}}', [("clear_preferred_steering_direction", {})]),
    ('{{"name": "set_reference_speed", "arguments": {"v_ref": 20}}}', [("set_reference_speed", {"v_ref": 20})]),
    ('{{"name": "run_right_lane", "arguments": {"v_ref": 15.0}}}', [("run_right_lane", {"v_ref": 15.0})]),
    ('```json\n{\n  "name": "run_center_lane",\n  "arguments": {\n    "v_ref": 0\n  }\n}\n```',
     [("run_center_lane", {"v_ref": 0})]),
]


@pytest.mark.parametrize(("text", "expected"), QWEN_1_5B)
def test_what_qwen_wrote_is_read_whole(text, expected):
    rest, calls = read(text)
    assert [(c.name, c.arguments) for c in calls] == expected and all(c.error is None for c in calls)
    assert rest == ""


@pytest.mark.parametrize(("text", "expected"), REAL_ANSWERS)
def test_calls_written_as_text_are_read(text, expected):
    assert calls_of(text) == expected
    assert all(c.error is None and c.id.startswith(TEXT_CALL_PREFIX) for c in read(text)[1])


def test_the_text_around_a_call_is_kept_as_the_reply():
    rest, calls = read('Sure, pulling over.\n```json\n{"name": "run_left_lane", "arguments": {"v_ref": 0}}\n```\nDone.')
    assert rest == "Sure, pulling over.\n\nDone." and len(calls) == 1


@pytest.mark.parametrize("text", [
    "What a nice day!",
    "I keep driving in the center lane at 15 m/s.",
    "The set {a, b} is not JSON, and neither is {this}.",
    "",
])
def test_prose_is_a_reply_without_a_call(text):
    rest, calls = read(text)
    assert calls == [] and rest == text.strip()


FAILED = [
    ('```json\n{"name": "run_left_lane", "arguments": {"v_ref": 0\n```', UNPARSED, "could not read the tool call"),
    ('{"name": "run_left_lane", "arguments": {"v_ref": 0', UNPARSED, "could not read the tool call"),
    ('{"name": "run_left_lane", "arguments": {"v_ref": NaN}}', UNPARSED, "NaN is not a valid JSON number"),
    ('{"name": "yield_to_ambulance", "arguments": {}}', "yield_to_ambulance", "unknown tool 'yield_to_ambulance'"),
    ('```json\n{"v_ref": 0}\n```', UNPARSED, "a JSON answer that is not a tool call"),
    ('{"name": "run_left_lane", "arguments": [0]}', "run_left_lane", "must be a JSON object"),
    ("run_left_lane(0)", "run_left_lane", "could not read the arguments"),
]


@pytest.mark.parametrize(("text", "name", "why"), FAILED)
def test_a_failed_call_is_an_error_with_the_expected_format_and_the_tool_names(text, name, why):
    _, (call,) = read(text)
    assert call.name == name and call.arguments is None and why in call.error
    assert '{"name": "<tool>", "arguments": {...}}' in call.error
    assert ", ".join(sorted(NAMES)) in call.error
    assert call.raw_arguments  # what the model wrote, for the transcript


def test_structured_replies_and_their_hint():
    assert read('{"reply": "Nice day indeed."}', structured=True) == ("Nice day indeed.", [])
    _, (call,) = read('{"name": "fly", "arguments": {}}', structured=True)
    assert '{"reply": "<a short answer>"}' in call.error


def test_doubled_braces_and_python_literals_load():
    assert load_json_like('{{"a": {{"b": 1}}}}') == ({"a": {"b": 1}}, None)
    assert load_json_like("{'a': True, 'b': None}") == ({"a": True, "b": None}, None)
    assert load_json_like("{'a': float('nan')}")[0] is None


def test_the_answer_schema_is_one_tool_with_its_arguments_or_a_reply():
    schema = answer_schema(TOOLS)
    jsonschema.Draft202012Validator.check_schema(schema)
    valid = [{"name": "run_left_lane", "arguments": {"v_ref": 0}}, {"reply": "Hello."},
             {"name": "clear_preferred_steering_direction", "arguments": {}},
             {"name": "set_preferred_steering_direction", "arguments": {"direction": "left"}}]
    invalid = [{"name": "run_left_lane", "arguments": {"v_ref": 99}}, {"name": "fly", "arguments": {}},
               {"name": "run_left_lane"}, {"reply": "x" * 301}, {"reply": "ok", "name": "run_left_lane"},
               {"name": "set_preferred_steering_direction", "arguments": {"direction": "up"}}, {}]
    for answer in valid:
        jsonschema.validate(answer, schema)
    for answer in invalid:
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(answer, schema)
    assert "title" not in json.dumps(schema)


def test_the_json_schema_request_and_its_history():
    backend = OpenAIBackend(OpenAISettings(tool_mode="json_schema", api_key_env=None, prompt="full"))
    call = ToolCall("c1", "run_left_lane", {"v_ref": 0}, '{"v_ref": 0}')
    history = [Message("system", "You drive."), Message("user", "Let them pass."),
               Message("assistant", "", tool_calls=(call,)),
               Message("tool", '{"applied": true}', tool_call_id="c1", name="run_left_lane"),
               Message("assistant", "Pulled over.")]
    body = backend.request_body(history, TOOLS)
    assert "tools" not in body and body["response_format"]["type"] == "json_schema"
    assert body["response_format"]["json_schema"]["schema"] == answer_schema(TOOLS)
    assert body["messages"] == [
        {"role": "system", "content": f"You drive.\n\n{STRUCTURED_INSTRUCTION}"},
        {"role": "user", "content": "Let them pass."},
        {"role": "assistant", "content": '{"name": "run_left_lane", "arguments": {"v_ref": 0}}'},
        {"role": "user", "content": '[result of run_left_lane] {"applied": true}\n'
                                    '(If the message asked for another change, call that tool now; '
                                    'else answer {"reply": ...}.)'},
        {"role": "assistant", "content": '{"reply": "Pulled over."}'},
    ]
    # answering tool results: the same calls, a shorter reply (it only confirms what the results say)
    after = backend.request_body(history[:4], TOOLS)["response_format"]["json_schema"]["schema"]
    assert after["oneOf"][:-1] == answer_schema(TOOLS)["oneOf"][:-1]
    assert after["oneOf"][-1]["properties"]["reply"]["maxLength"] == REPLY_AFTER_RESULTS_CHARS < REPLY_MAX_CHARS
    reply = backend.parse_message({"content": '{"name": "run_left_lane", "arguments": {"v_ref": 0}}'}, NAMES)
    assert [(c.name, c.arguments) for c in reply.tool_calls] == LEFT_0 and reply.text == ""
    assert backend.parse_message({"content": '{"reply": "Nice day."}'}, NAMES).text == "Nice day."


def test_native_history_echoes_text_calls_as_the_text_the_model_wrote():
    written = ToolCall(f"{TEXT_CALL_PREFIX}1", UNPARSED, None, '{"name": "run_left_lane", "arguments": {', "bad")
    history = [Message("system", "s"), Message("user", "u"),
               Message("assistant", "Pulling over.", tool_calls=(written,)),
               Message("tool", "Error: bad", tool_call_id=written.id, name=UNPARSED, is_error=True)]
    messages = render_messages(history, "native")
    assert messages[2] == {"role": "assistant",
                           "content": 'Pulling over.\n{"name": "run_left_lane", "arguments": {'}
    assert messages[3] == {"role": "user", "content": f"[result of {UNPARSED}] Error: bad"}
    assert messages[0] == {"role": "system", "content": "s"}
