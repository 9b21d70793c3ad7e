"""A language model behind any OpenAI-compatible chat-completions endpoint with tool calling.

Works with Ollama, vLLM, the llama.cpp server, LM Studio and OpenAI itself, over plain HTTP with ``httpx``
(no ``openai`` package). The MCP tools become function tools (their JSON schemas as ``parameters``); the
model's answer becomes an agent message. Every tool call is parsed strictly here (JSON object arguments; NaN
and Infinity refused) and validated by the agent against the MCP schema before anything is sent to the
controller: a malformed call (unknown tool, invalid JSON, wrong type, out of range) goes back to the model
as a tool-error message, so it can correct itself, a bounded number of times. Transport failures (refused
connection, timeout, HTTP error, a body that is not a chat completion) raise :class:`BackendError`, which
the agent retries and then records; the car keeps its last valid specification.

Models that write tool calls as text (``<tool_call>{"name": ..., "arguments": {...}}</tool_call>``, as
Granite and Qwen templates do when the server does not parse them) are understood too.

Running the paper's model family (IBM Granite) under Ollama
-----------------------------------------------------------
The paper used IBM Granite 4.1 8B. Ollama's library has the Granite 4 family with tool calling::

    ollama pull granite4:micro          # 3B dense; also granite4:tiny-h (7B MoE), granite4:small-h (32B MoE)
    ollama serve                        # OpenAI-compatible API at http://localhost:11434/v1
    agentic-mpc ask "An ambulance is coming behind us. We'd better let them pass." \\
        --backend openai --base-url http://localhost:11434/v1 --model granite4:micro --json

For a Granite 4.1 8B GGUF file, import it: a ``Modelfile`` with ``FROM ./granite-4.1-8b-instruct.gguf``,
then ``ollama create granite4.1-8b -f Modelfile`` and ``--model granite4.1-8b``. Ollama needs no API key;
for a hosted endpoint put the key in an environment variable and name it with ``--api-key-env``.
vLLM: ``vllm serve ibm-granite/<model> --enable-auto-tool-choice --tool-call-parser granite`` then
``--base-url http://localhost:8000/v1``. llama.cpp: ``llama-server -m model.gguf --jinja`` then
``--base-url http://localhost:8080/v1``.
"""

from __future__ import annotations

import itertools
import json
import os
import re
from collections.abc import Sequence
from typing import Any

import httpx
from pydantic import BaseModel, ConfigDict, Field

from agentic_mpc.agent.backends.base import BackendError, BackendReply, ToolSpec
from agentic_mpc.agent.messages import Message, ToolCall

DEFAULT_BASE_URL = "http://localhost:11434/v1"
DEFAULT_MODEL = "granite4:micro"
_TEXT_TOOL_CALL = re.compile(r"<tool_call>\s*(.*?)\s*</tool_call>", re.DOTALL)


class OpenAIConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    base_url: str = Field(DEFAULT_BASE_URL, description="the endpoint's /v1 URL")
    model: str = DEFAULT_MODEL
    api_key_env: str | None = Field("OPENAI_API_KEY", description="environment variable holding the API key")
    timeout_s: float = Field(120.0, gt=0, description="per HTTP request")
    temperature: float = Field(0.0, ge=0, le=2)
    max_tokens: int | None = Field(512, ge=1)
    extra_body: dict[str, Any] = Field(default_factory=dict, description="merged into every request body")


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a valid JSON number")


def parse_arguments(raw: Any) -> tuple[dict[str, Any] | None, str | None]:
    """(arguments, None) or (None, why not): a JSON object with finite numbers, or an error message."""
    if isinstance(raw, dict):
        return raw, None
    if raw is None or (isinstance(raw, str) and not raw.strip()):
        return {}, None
    if not isinstance(raw, str):
        return None, f"arguments must be a JSON object, got {type(raw).__name__}"
    try:
        value = json.loads(raw, parse_constant=_reject_constant)
    except ValueError as error:
        return None, f"arguments are not valid JSON ({error}): {raw[:200]!r}"
    if not isinstance(value, dict):
        return None, f"arguments must be a JSON object, got {type(value).__name__}: {raw[:200]!r}"
    return value, None


class OpenAIBackend:
    """Chat completions with tools over HTTP (see the module docstring)."""

    name = "openai"

    def __init__(self, config: OpenAIConfig | None = None) -> None:
        self.config = config or OpenAIConfig()
        self._client: httpx.AsyncClient | None = None
        self._ids = itertools.count(1)

    @property
    def url(self) -> str:
        return self.config.base_url.rstrip("/") + "/chat/completions"

    def _headers(self) -> dict[str, str]:
        headers = {"Content-Type": "application/json"}
        key = os.environ.get(self.config.api_key_env) if self.config.api_key_env else None
        if key:
            headers["Authorization"] = f"Bearer {key}"
        return headers

    def request_body(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> dict[str, Any]:
        body: dict[str, Any] = {
            "model": self.config.model,
            "messages": [m.to_openai() for m in history],
            "temperature": self.config.temperature,
        }
        if tools:
            body["tools"] = [t.to_openai() for t in tools]
            body["tool_choice"] = "auto"
        if self.config.max_tokens is not None:
            body["max_tokens"] = self.config.max_tokens
        body.update(self.config.extra_body)
        return body

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        if self._client is None:
            self._client = httpx.AsyncClient(timeout=self.config.timeout_s)
        body = self.request_body(history, tools)
        try:
            response = await self._client.post(self.url, json=body, headers=self._headers())
        except httpx.TimeoutException as error:
            raise BackendError(f"{self.url} did not answer within {self.config.timeout_s:g} s") from error
        except httpx.HTTPError as error:
            raise BackendError(f"cannot reach {self.url}: {error!r}") from error
        if response.status_code >= 400:
            raise BackendError(f"{self.url} answered HTTP {response.status_code}: {response.text[:300]!r}")
        try:
            data = response.json()
            message = data["choices"][0]["message"]
            if not isinstance(message, dict):
                raise TypeError("message is not an object")
        except (ValueError, KeyError, IndexError, TypeError) as error:
            raise BackendError(f"{self.url} sent no chat completion ({error!r}): {response.text[:300]!r}") from error
        return self.parse_message(message)

    def parse_message(self, message: dict[str, Any]) -> BackendReply:
        """An OpenAI ``message`` object to an agent message; malformed tool calls are kept, marked with why."""
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
            for block in _TEXT_TOOL_CALL.findall(text):
                calls.extend(self._text_calls(block))
            if calls:
                text = _TEXT_TOOL_CALL.sub("", text).strip()
        return BackendReply(text, tuple(calls))

    def _new_id(self) -> str:
        return f"call_{next(self._ids)}"

    def _call(self, call_id: str, name: str, raw_arguments: Any) -> ToolCall:
        arguments, error = parse_arguments(raw_arguments)
        raw = raw_arguments if isinstance(raw_arguments, str) else json.dumps(raw_arguments, default=str)
        return ToolCall(call_id, name, arguments, raw or "{}", error)

    def _text_calls(self, block: str) -> list[ToolCall]:
        try:
            value = json.loads(block, parse_constant=_reject_constant)
        except ValueError as error:
            return [ToolCall(self._new_id(), "", None, block[:500], f"tool call text is not valid JSON ({error})")]
        items = value if isinstance(value, list) else [value]
        calls = []
        for item in items:
            if not isinstance(item, dict) or not isinstance(item.get("name"), str):
                calls.append(ToolCall(self._new_id(), "", None, json.dumps(item)[:500], "a tool call without a name"))
                continue
            calls.append(self._call(self._new_id(), item["name"], item.get("arguments", item.get("parameters"))))
        return calls

    async def aclose(self) -> None:
        if self._client is not None:
            await self._client.aclose()
            self._client = None
