"""The two ways a chat backend asks for tool calls (``tool_mode``), and the history as each one sends it.

``native``: the MCP tools go out as function tools (``tools``, ``tool_choice: auto``); the endpoint parses the
model's calls into ``tool_calls``, and calls it left in the text are read by
:mod:`~agentic_mpc.agent.backends.call_parsing`.

``json_schema``: no ``tools``; the request carries ``response_format: {"type": "json_schema", ...}`` with a
schema built from the MCP tools' input schemas, :func:`answer_schema`: one of the tools with its arguments
(``{"name": "<tool>", "arguments": {...}}``), or no call with a short reply (``{"reply": "..."}``). Servers
with constrained decoding (llama.cpp, vLLM, Ollama, LM Studio, OpenAI) then cannot answer anything else; for
endpoints whose tool parsing is missing or unreliable. The system message gets a paragraph saying so.

In both modes, calls that were read from text (and, in ``json_schema`` mode, every call) are sent back to
the model as the text it wrote, and their results as user messages: many chat templates drop ``tool_calls``
and ``tool`` messages they do not know, and the model must see what it did.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any, Literal

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.call_parsing import TEXT_CALL_PREFIX
from agentic_mpc.agent.messages import Message, ToolCall

ToolMode = Literal["native", "json_schema"]
TOOL_MODES: tuple[str, ...] = ("native", "json_schema")
REPLY_MAX_CHARS = 300
REPLY_AFTER_RESULTS_CHARS = 80
"""A reply right after tool results only confirms what they say: kept short, since each generated token costs
a small model on a CPU about as much as reading four (docs/llm-backends.md, "An answer in time")."""

STRUCTURED_INSTRUCTION = (
    "Answer format: exactly one JSON object and nothing else.\n"
    '- When the passenger\'s message asks for a change, call the tool that makes it: '
    '{"name": "<tool name>", "arguments": {<its arguments>}}.\n'
    '- Only when nothing must change (small talk, a question, after the tool result that did it): '
    '{"reply": "<a short answer>"}.'
)


ANSWER_FORMAT_MARK = "Answer with one JSON object"
"""A system message that says the answer format itself (the compact prompt) gets no second paragraph."""

_AFTER_RESULTS = '\n(If the message asked for another change, call that tool now; else answer {"reply": ...}.)'


def answer_schema(tools: Sequence[ToolSpec], reply_chars: int = REPLY_MAX_CHARS,
                  cites: Sequence[str] = ()) -> dict[str, Any]:
    """The JSON schema of one answer: one of the tools with its arguments, or a reply of at most
    ``reply_chars`` without a call; with ``cites`` (the documents retrieved for the message) the reply names
    one of them, ``{"reply": ..., "cite": "<id>"}``."""
    options: list[dict[str, Any]] = []
    for tool in tools:
        parameters = tool.to_openai()["function"]["parameters"]
        parameters.setdefault("type", "object")
        parameters.setdefault("properties", {})
        options.append({
            "type": "object",
            "properties": {"name": {"type": "string", "const": tool.name}, "arguments": parameters},
            "required": ["name", "arguments"],
            "additionalProperties": False,
        })
    reply: dict[str, Any] = {"reply": {"type": "string", "maxLength": reply_chars}}
    if cites:
        reply["cite"] = {"type": "string", "enum": list(cites)}
    options.append({
        "type": "object",
        "properties": reply,
        "required": list(reply),
        "additionalProperties": False,
    })
    return {"oneOf": options}


def response_format(tools: Sequence[ToolSpec], after_results: bool = False,
                    cites: Sequence[str] = ()) -> dict[str, Any]:
    """The chat-completions ``response_format`` of the structured mode (``after_results``: the answer to tool
    results, whose reply is kept short; ``cites``: documents the reply must name one of)."""
    schema = answer_schema(tools, REPLY_AFTER_RESULTS_CHARS if after_results else REPLY_MAX_CHARS, cites)
    return {"type": "json_schema", "json_schema": {"name": "agent_answer", "schema": schema, "strict": True}}


def _written(call: ToolCall) -> str:
    """A call as the model wrote it (what could not be read: as it was)."""
    if call.error is None and call.arguments is not None:
        return json.dumps({"name": call.name, "arguments": call.arguments})
    return call.raw_arguments or "{}"


def render_messages(history: Sequence[Message], tool_mode: ToolMode) -> list[dict[str, Any]]:
    """The chat-completions ``messages`` for ``history`` in ``tool_mode`` (see the module docstring)."""
    structured = tool_mode == "json_schema"
    as_text: set[str] = set()
    out: list[dict[str, Any]] = []
    for message in history:
        calls = message.tool_calls
        if message.role == "assistant" and (structured or (calls and all(
                c.id.startswith(TEXT_CALL_PREFIX) for c in calls))):
            as_text.update(c.id for c in calls)
            if structured:
                parts = [_written(c) for c in calls] or [json.dumps({"reply": message.content[:REPLY_MAX_CHARS]})]
            else:
                parts = ([message.content] if message.content else []) + [_written(c) for c in calls]
            out.append({"role": "assistant", "content": "\n".join(parts)})
        elif message.role == "tool" and (structured or message.tool_call_id in as_text):
            line = f"[result of {message.name}] {message.content}"
            if out and out[-1].get("role") == "user" and out[-1].get("content", "").startswith("[result of "):
                out[-1]["content"] = out[-1]["content"].removesuffix(_AFTER_RESULTS) + "\n" + line
            else:
                out.append({"role": "user", "content": line})
            if structured:  # a small model repeats a call it sees no end to
                out[-1]["content"] += _AFTER_RESULTS
        else:
            out.append(message.to_openai())
    if structured and out and out[0]["role"] == "system" and ANSWER_FORMAT_MARK not in out[0]["content"]:
        out[0] = {**out[0], "content": f"{out[0]['content']}\n\n{STRUCTURED_INSTRUCTION}"}
    return out
