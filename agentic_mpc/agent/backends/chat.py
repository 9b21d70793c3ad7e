"""What every chat-completions backend shares: the request it builds and how it reads the answer.

:class:`ChatBackend` builds an OpenAI chat-completions request from the history and the MCP tools (in
``tool_mode`` ``native`` or ``json_schema``, :mod:`~agentic_mpc.agent.backends.structured`) and turns the
answer's ``message`` into an agent message: native ``tool_calls`` parsed strictly (JSON object arguments;
NaN and Infinity refused), else the calls written in the text
(:mod:`~agentic_mpc.agent.backends.call_parsing`). A malformed or unreadable call is kept, marked with why:
the agent answers it with a tool error the model can act on, and records it. Subclasses only send the
request: over HTTP (:mod:`~agentic_mpc.agent.backends.openai`) or in process
(:mod:`~agentic_mpc.agent.backends.llamacpp`).
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Sequence
from typing import Any

from agentic_mpc.agent.backends.base import BackendError, BackendReply, ModelUsage, ToolSpec
from agentic_mpc.agent.backends.call_parsing import TEXT_CALL_PREFIX, calls_from_text, parse_arguments
from agentic_mpc.agent.backends.context import ContextWindow
from agentic_mpc.agent.backends.structured import render_messages, response_format
from agentic_mpc.agent.messages import Message, ToolCall
from agentic_mpc.agent.settings import ChatSettings


class ChatBackend:
    """Chat completions with tools (see the module docstring); subclasses implement :meth:`send`."""

    name = "chat"
    reads_situation = True
    config: ChatSettings

    def __init__(self) -> None:
        self._ids = itertools.count(1)
        self._text_ids = itertools.count(1)
        self._window: ContextWindow | None = None

    @property
    def window(self) -> ContextWindow:
        """What part of the history fits the model's context (agent/backends/context.py)."""
        if self._window is None:
            self._window = ContextWindow(self.config.context_limit_tokens)
        return self._window

    def request_body(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> dict[str, Any]:
        body: dict[str, Any] = {
            "messages": render_messages(self.window.fit(history), self.config.effective_tool_mode),
            "temperature": self.config.temperature,
        }
        if self.config.effective_tool_mode == "json_schema":
            after_results = bool(history) and history[-1].role == "tool"
            body["response_format"] = response_format(tools, after_results=after_results)
        elif tools:
            body["tools"] = [t.to_openai() for t in tools]
            body["tool_choice"] = "auto"
        if self.config.max_tokens is not None:
            body["max_tokens"] = self.config.max_tokens
        body.update(self.config.extra_body)
        return body

    async def send(self, body: dict[str, Any]) -> dict[str, Any]:
        """The chat completion for ``body`` (a dict with ``choices``); :class:`BackendError` if none."""
        raise NotImplementedError

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        data = await self.send(self.request_body(history, tools))
        try:
            message = data["choices"][0]["message"]
            if not isinstance(message, dict):
                raise TypeError("message is not an object")
        except (KeyError, IndexError, TypeError) as error:
            raise BackendError(f"{self.name}: no chat completion ({error!r}): {json.dumps(data)[:300]!r}") from error
        reply = self.parse_message(message, [t.name for t in tools])
        return BackendReply(reply.text, reply.tool_calls, ModelUsage.from_response(data))

    async def warm(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> ModelUsage | None:
        """Have the model read ``history`` (the system message) into its prompt cache: a request for one
        token, with the same tools and format as every later request, so that they share its tokens."""
        body = {**self.request_body(history, tools), "max_tokens": 1}
        return ModelUsage.from_response(await self.send(body))

    def parse_message(self, message: dict[str, Any], tool_names: Sequence[str] = ()) -> BackendReply:
        """An OpenAI ``message`` object to an agent message; malformed tool calls are kept, marked with why.

        ``tool_names``: the listed tools, for calls written in the text (without them, any name is taken and
        left to the agent's check)."""
        content = message.get("content")
        text = content if isinstance(content, str) else ""
        calls: list[ToolCall] = []
        raw_calls = message.get("tool_calls") or []
        if not isinstance(raw_calls, list):
            raw_calls = [raw_calls]
        for raw in raw_calls:
            raw = raw if isinstance(raw, dict) else {"function": raw}
            call_id = str(raw.get("id") or self._new_id())
            function = raw.get("function")
            if not isinstance(function, dict) or not isinstance(function.get("name"), str):
                shown = json.dumps(raw, default=str)[:500]
                calls.append(ToolCall(call_id, "", None, shown, "a tool call without a function name"))
                continue
            calls.append(self._call(call_id, function["name"], function.get("arguments")))
        if not calls and text:
            structured = self.config.effective_tool_mode == "json_schema"
            text, read = calls_from_text(text, tool_names, self._new_text_id, structured=structured)
            calls.extend(read)
        return BackendReply(text, tuple(calls))

    def _new_id(self) -> str:
        return f"call_{next(self._ids)}"

    def _new_text_id(self) -> str:
        return f"{TEXT_CALL_PREFIX}{next(self._text_ids)}"

    @staticmethod
    def _call(call_id: str, name: str, raw_arguments: Any) -> ToolCall:
        arguments, error = parse_arguments(raw_arguments)
        raw = raw_arguments if isinstance(raw_arguments, str) else json.dumps(raw_arguments, default=str)
        return ToolCall(call_id, name, arguments, raw or "{}", error)

    async def aclose(self) -> None:
        """Release what the backend holds."""
