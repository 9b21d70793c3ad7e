"""A language model behind any OpenAI-compatible chat-completions endpoint with tool calling.

Works with Ollama, vLLM, the llama.cpp server, LM Studio and OpenAI itself, over plain HTTP with ``httpx``
(no ``openai`` package). The MCP tools become function tools (their JSON schemas as ``parameters``); the
model's answer becomes an agent message (the request and the reading of the answer are shared with the
in-process ``llamacpp`` backend, :mod:`~agentic_mpc.agent.backends.chat`). Every tool call is parsed strictly
(JSON object arguments; NaN and Infinity refused) and validated by the agent against the MCP schema before anything is sent to the
controller: a malformed call (unknown tool, invalid JSON, wrong type, out of range) goes back to the model
as a tool-error message, so it can correct itself, a bounded number of times. Transport failures (refused
connection, timeout, HTTP error, a body that is not a chat completion) raise :class:`BackendError`, which
the agent retries and then records; the car keeps its last valid specification.

Models that write tool calls as text (in ``<tool_call>`` tags, Markdown code fences, bare JSON, with doubled
braces, as Granite and Qwen templates do when the server does not parse them) are understood too
(:mod:`~agentic_mpc.agent.backends.call_parsing`); text that looks like a failed call is an error the model
is told about. ``tool_mode="json_schema"`` asks for the answer as JSON under a schema built from the MCP
tools instead of native tool calling (:mod:`~agentic_mpc.agent.backends.structured`), for endpoints whose
tool parsing is missing or unreliable. See docs/llm-backends.md.

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

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field

from agentic_mpc.agent.backends.base import Backend, BackendError, ToolSpec
from agentic_mpc.agent.backends.call_parsing import parse_arguments
from agentic_mpc.agent.backends.chat import ChatBackend, ChatSettings
from agentic_mpc.agent.messages import Message

if TYPE_CHECKING:  # httpx is imported when the backend first sends: a scenario's settings load without it
    import httpx


class OpenAISettings(ChatSettings):
    """Any OpenAI-compatible chat-completions endpoint (Ollama, vLLM, llama.cpp's server, OpenAI)."""

    backend: Literal["openai"] = "openai"
    base_url: str = Field("http://localhost:11434/v1", description="the endpoint's /v1 URL (default Ollama's)")
    model: str = Field("granite4:micro", description="the model name")
    api_key_env: str | None = Field("OPENAI_API_KEY", description="environment variable holding the API key "
                                    "(sent as a bearer token when it is set; null: never)")

    def build_backend(self, lefthand: bool) -> Backend:
        return self.with_rules_first(OpenAIBackend(self), lefthand)


class OpenAIBackend(ChatBackend):
    """Chat completions with tools over HTTP (see the module docstring)."""

    name = "openai"

    def __init__(self, config: OpenAISettings | None = None) -> None:
        super().__init__()
        self.config: OpenAISettings = config or OpenAISettings()
        self._client: httpx.AsyncClient | None = None

    @property
    def url(self) -> str:
        return self.config.base_url.rstrip("/") + "/chat/completions"

    def _headers(self) -> dict[str, str]:
        headers = {"Content-Type": "application/json"}
        key = os.environ.get(self.config.api_key_env) if self.config.api_key_env else None
        if key:
            headers["Authorization"] = f"Bearer {key}"
        return headers

    def request_body(self, history: Sequence[Message], tools: Sequence[ToolSpec],
                     undone: dict[str, str] | None = None) -> dict[str, Any]:
        return {"model": self.config.model, **super().request_body(history, tools, undone)}

    async def send(self, body: dict[str, Any]) -> dict[str, Any]:
        import httpx

        if self._client is None:
            self._client = httpx.AsyncClient(timeout=self.config.timeout_s)
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
            if not isinstance(data["choices"][0]["message"], dict):
                raise TypeError("message is not an object")
        except (ValueError, KeyError, IndexError, TypeError) as error:
            raise BackendError(f"{self.url} sent no chat completion ({error!r}): {response.text[:300]!r}") from error
        return data

    async def aclose(self) -> None:
        if self._client is not None:
            await self._client.aclose()
            self._client = None


__all__ = ["OpenAIBackend", "OpenAISettings", "parse_arguments"]
