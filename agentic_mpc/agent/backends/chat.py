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
from dataclasses import replace
from typing import Any, ClassVar, Literal

from pydantic import Field

from agentic_mpc.agent.backends.base import Backend, BackendError, BackendReply, ModelUsage, ToolSpec
from agentic_mpc.agent.backends.call_parsing import TEXT_CALL_PREFIX, calls_from_text, parse_arguments
from agentic_mpc.agent.backends.context import ContextWindow
from agentic_mpc.agent.backends.follow_up import follow_up_note, left_undone, template_reply
from agentic_mpc.agent.backends.structured import ToolMode, render_messages, response_format
from agentic_mpc.agent.compact_prompt import compact_history, compact_system_prompt
from agentic_mpc.agent.config import AgentConfig, AgentRunSettings
from agentic_mpc.agent.messages import Message, ToolCall
from agentic_mpc.agent.prompt import system_prompt as full_system_prompt
from agentic_mpc.agent.retrieval import SEARCH_SUFFIX, compact_search_result
from agentic_mpc.agent.toolset import Toolset, converted, model_facing, offered, short_description, signature


class ChatSettings(AgentRunSettings):
    """What both language-model backends have (each adds its ``backend`` and how it reaches the model)."""

    DEFAULT_TOOL_MODE: ClassVar[ToolMode] = "native"
    tool_mode: ToolMode | None = Field(
        None, description="native tool calls, or the answer constrained to one call or a reply by a JSON schema "
                          "of the tools (default: native for openai, json_schema for llamacpp)")
    temperature: float = Field(0.0, ge=0, le=2, description="sampling temperature")
    max_tokens: int = Field(512, ge=1, le=32768, description="tokens per answer")
    extra_body: dict[str, Any] = Field(default_factory=dict, description="merged into every request body "
                                                                         "(e.g. top_p)")
    timeout_s: float = Field(120.0, gt=0, description="seconds per answer; the agent step's own timeout is this "
                                                      "plus 5 s, so the backend's runs out first")
    context_tokens: int | None = Field(
        None, ge=256, description="the model's context in tokens: older steps of the history are left out of a "
                                  "request that would not fit (null: never; llamacpp: its ctx_size)")
    rules_first: bool = Field(False, description="the rules backend answers what it understands, the model the "
                                                 "rest (agent/backends/rules_first.py)")
    prompt: Literal["compact", "full"] = Field(
        "compact", description="compact: the system message a small model can use (the tools of this road, one "
                               "line each, speeds with a unit; agent/compact_prompt.py); full: every tool with "
                               "its whole description (agent/prompt.py)")
    toolset: Toolset = Field(
        "auto", description="compact prompt: the tools offered to the model (auto and paper: the paper's; "
                            "lampilot: with LaMPilot's manoeuvres; all), the rest when a message asks for them "
                            "(agent/toolset.py)")
    confirmation: Literal["template", "model"] = Field(
        "template", description="compact prompt, after calls that all succeeded: template: when they made every "
                                "kind of change the message asks for, the reply is written from their results "
                                "(citing the passages retrieved for the message) without asking the model, else "
                                "the model is told what is left; model: the model answers the results "
                                "(agent/backends/follow_up.py)")

    def agent_config(self, **runtime: Any) -> AgentConfig:
        runtime.setdefault("backend_timeout_s", self.timeout_s + 5.0)  # the backend's own timeout runs out first
        return super().agent_config(**runtime)

    def with_rules_first(self, model: Backend, lefthand: bool) -> Backend:
        """``model``, or the rules in front of it when ``rules_first`` is set."""
        if not self.rules_first:
            return model
        from agentic_mpc.agent.backends.rules import RulesBackend
        from agentic_mpc.agent.backends.rules_first import RulesFirst

        return RulesFirst(RulesBackend(yield_lane="left" if lefthand else "right"), model)

    @property
    def context_limit_tokens(self) -> int | None:
        """The history must fit into this many tokens (None: no limit known)."""
        return None if self.context_tokens is None else max(128, self.context_tokens - self.max_tokens)

    @property
    def effective_tool_mode(self) -> ToolMode:
        return self.tool_mode or self.DEFAULT_TOOL_MODE


def retrieved_ids(history: Sequence[Message]) -> tuple[str, ...]:
    """The documents retrieved for the step being answered (the last message from outside the model's own
    answers, ``data["retrieved"]``: agent/retrieval.py), for the reply to cite."""
    for message in reversed(history):
        if message.role == "user" and message.source != "agent":
            found = (message.data or {}).get("retrieved") or []
            return tuple(dict.fromkeys(str(item) for item in found))
    return ()


def law_limit(history: Sequence[Message]) -> tuple[float, str] | None:
    """The law's speed limit on this road found for the step being answered (``data["law_limit"]``:
    agent/retrieval.py), as (m/s, where it comes from), or None."""
    for message in reversed(history):
        if message.role == "user" and message.source != "agent":
            found = (message.data or {}).get("law_limit")
            if isinstance(found, dict) and isinstance(found.get("mps"), int | float):
                return float(found["mps"]), str(found.get("why") or "")
            return None
    return None


def _this_step(history: Sequence[Message]) -> Sequence[Message]:
    """The step being answered: from the last message from outside the model's own answers on."""
    starts = [i for i, m in enumerate(history) if m.role == "user" and m.source != "agent"]
    return history[starts[-1]:] if starts else ()


def is_question(message: str | None) -> bool:
    """Whether the passenger asks a question ("What should we do for an ambulance?"; not a request put as one,
    "could you ...?", "shall we?"), as the rules read it (``rules_parsing.interpret``): it gets a reply, never
    a call. With an ambulance near, Qwen 1.5B answered 9 of 26 such questions with the yield call although
    the system message says so; in ``json_schema`` mode the answer's schema now says it too."""
    if not message or not message.strip():
        return False
    from agentic_mpc.agent.backends.rules_parsing import interpret

    return interpret(message).question


class ChatBackend:
    """Chat completions with tools (see the module docstring); subclasses implement :meth:`send`."""

    name = "chat"
    reads_situation = True
    config: ChatSettings

    def __init__(self) -> None:
        self._all_tools: list[ToolSpec] = []
        self._ids = itertools.count(1)
        self._text_ids = itertools.count(1)
        self._window: ContextWindow | None = None

    @property
    def window(self) -> ContextWindow:
        """What part of the history fits the model's context (agent/backends/context.py)."""
        if self._window is None:
            self._window = ContextWindow(self.config.context_limit_tokens)
        return self._window

    @property
    def compact(self) -> bool:
        return self.config.prompt == "compact"

    def system_prompt(self, initial: dict[str, Any] | None, tools: Sequence[ToolSpec], extra: str = "",
                      road: dict[str, Any] | None = None) -> str:
        """The system message this backend's model reads (the agent asks for it when it starts)."""
        if not self.compact:
            return full_system_prompt(initial, tools, extra, road=road)
        return compact_system_prompt(initial, tools, extra, road=road, toolset=self.config.toolset,
                                     tool_mode=self.config.effective_tool_mode)

    def offered_tools(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> list[ToolSpec]:
        """What the model is shown for the step being answered: every tool (full prompt), or the toolset's
        and those the step's message asks for, speeds with a unit (compact; agent/toolset.py). A question
        (:func:`is_question`) in ``json_schema`` mode: no tool of the car, so the answer is a reply (the
        knowledge search if nothing was retrieved for it)."""
        if not self.compact:
            return list(tools)
        asked = next((m.content for m in reversed(history) if m.role == "user" and m.source != "agent"), None)
        shown = [model_facing(t) for t in offered(tools, self.config.toolset, asked)]
        if self.config.effective_tool_mode == "json_schema" and is_question(asked):
            # the search only where nothing was retrieved for it: offered beside passages, Qwen 1.5B searched
            # again and again and never replied
            searched = any(m.role == "tool" and (m.name or "").endswith(SEARCH_SUFFIX) for m in _this_step(history))
            return [] if retrieved_ids(history) or searched else [t for t in shown if t.name.endswith(SEARCH_SUFFIX)]
        return shown

    def _rendered(self, history: Sequence[Message], shown: Sequence[ToolSpec],
                  undone: dict[str, str] | None = None) -> list[dict[str, Any]]:
        fitted = self.window.fit(history)
        if self.compact:  # the situation and the earlier steps in a few lines; tools the message brought named
            fitted = [replace(m, content=compact_search_result(m.content)) if m.role == "tool"
                      and (m.name or "").endswith(SEARCH_SUFFIX) else m for m in compact_history(fitted)]
            base = {t.name for t in offered(self._all_tools, self.config.toolset)}
            extra = [t for t in shown if t.name not in base]
            if extra and fitted and fitted[-1].role == "user":
                note = "Also for this message: " + "; ".join(f"{signature(t)}: {short_description(t)}" for t in extra)
                fitted[-1] = replace(fitted[-1], context="\n\n".join(filter(None, [fitted[-1].context, note])))
            if undone:  # what the message asked and the step's calls have not done yet (follow_up.py)
                fitted[-1] = replace(fitted[-1], content=f"{fitted[-1].content} {follow_up_note(undone)}")
        return render_messages(fitted, self.config.effective_tool_mode)

    def request_body(self, history: Sequence[Message], tools: Sequence[ToolSpec],
                     undone: dict[str, str] | None = None) -> dict[str, Any]:
        self._all_tools = list(tools)
        shown = self.offered_tools(history, tools)
        body: dict[str, Any] = {
            "messages": self._rendered(history, shown, undone),
            "temperature": self.config.temperature,
        }
        if self.config.effective_tool_mode == "json_schema":
            after_results = bool(history) and history[-1].role == "tool"
            body["response_format"] = response_format(shown, after_results=after_results,
                                                      cites=retrieved_ids(history) if self.compact else ())
        elif shown:  # the tools a message brought are named in it: a stable list keeps the cached prefix
            stable = {t.name for t in offered(tools, self.config.toolset)} if self.compact else None
            body["tools"] = [t.to_openai() for t in shown if stable is None or t.name in stable]
            body["tool_choice"] = "auto"
        if self.config.max_tokens is not None:
            body["max_tokens"] = self.config.max_tokens
        body.update(self.config.extra_body)
        return body

    async def send(self, body: dict[str, Any]) -> dict[str, Any]:
        """The chat completion for ``body`` (a dict with ``choices``); :class:`BackendError` if none."""
        raise NotImplementedError

    @property
    def follows_up(self) -> bool:
        return self.compact and self.config.confirmation == "template"

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        undone = left_undone(history) if self.follows_up else None
        if undone == {}:  # all done: the results say it, with the passages cited
            return BackendReply(template_reply(history, retrieved_ids(history)))
        data = await self.send(self.request_body(history, tools, undone))
        try:
            message = data["choices"][0]["message"]
            if not isinstance(message, dict):
                raise TypeError("message is not an object")
        except (KeyError, IndexError, TypeError) as error:
            raise BackendError(f"{self.name}: no chat completion ({error!r}): {json.dumps(data)[:300]!r}") from error
        reply = self.parse_message(message, [t.name for t in tools])
        calls, text = list(reply.tool_calls), reply.text
        if self.compact:  # speeds to m/s, within the limit (agent/toolset.py): the model's units not trusted
            notes, law = [], law_limit(history)
            for index, call in enumerate(calls):
                calls[index], note = converted(call, tools, law)
                notes += [note] if note else []
            text = " ".join([text, *notes]).strip() if notes else text
        return BackendReply(text, tuple(calls), ModelUsage.from_response(data))

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
