"""What the agent asks of a backend: given the history and the tools, the next agent message."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from agentic_mpc.agent.messages import Message, ToolCall


@dataclass(frozen=True, slots=True)
class ToolSpec:
    """A tool as the MCP server lists it."""

    name: str
    description: str
    input_schema: dict[str, Any]

    def to_openai(self) -> dict[str, Any]:
        """The chat-completions function tool for this MCP tool."""
        schema = {k: v for k, v in self.input_schema.items() if k != "title"}
        schema["properties"] = {
            name: {k: v for k, v in prop.items() if k != "title"}
            for name, prop in schema.get("properties", {}).items()
        }
        function = {"name": self.name, "description": self.description, "parameters": schema}
        return {"type": "function", "function": function}

    def number_bounds(self, argument: str) -> tuple[float | None, float | None]:
        prop = self.input_schema.get("properties", {}).get(argument, {})
        return prop.get("minimum"), prop.get("maximum")


@dataclass(frozen=True, slots=True)
class ModelUsage:
    """What one answer cost the model, as its server reports it (llama.cpp's ``timings``; other
    OpenAI-compatible servers report tokens in ``usage`` and no times: then the times are None)."""

    prompt_tokens: int = 0
    """Prompt tokens the model processed for this answer (not those it had cached)."""
    cached_tokens: int = 0
    """Prompt tokens taken from the server's cache."""
    generated_tokens: int = 0
    prompt_s: float | None = None
    generation_s: float | None = None

    @property
    def model_s(self) -> float | None:
        """The model's own time for the answer (prompt processing + generation), if the server said."""
        if self.prompt_s is None and self.generation_s is None:
            return None
        return (self.prompt_s or 0.0) + (self.generation_s or 0.0)

    @classmethod
    def from_response(cls, data: dict[str, Any]) -> ModelUsage | None:
        """From a chat completion: llama.cpp's ``timings`` (tokens and milliseconds), else ``usage``."""
        timings = data.get("timings")
        if isinstance(timings, dict) and isinstance(timings.get("prompt_n"), int | float):
            def seconds(key: str) -> float | None:
                value = timings.get(key)
                return float(value) / 1000.0 if isinstance(value, int | float) else None
            return cls(int(timings.get("prompt_n") or 0), int(timings.get("cache_n") or 0),
                       int(timings.get("predicted_n") or 0), seconds("prompt_ms"), seconds("predicted_ms"))
        usage = data.get("usage")
        if isinstance(usage, dict) and isinstance(usage.get("prompt_tokens"), int | float):
            details = usage.get("prompt_tokens_details")
            cached = int(details.get("cached_tokens") or 0) if isinstance(details, dict) else 0
            return cls(int(usage["prompt_tokens"]) - cached, cached, int(usage.get("completion_tokens") or 0))
        return None


@dataclass(frozen=True, slots=True)
class BackendReply:
    """An agent message: text and tool invocation requests (possibly none), and what it cost the model."""

    text: str
    tool_calls: tuple[ToolCall, ...] = ()
    usage: ModelUsage | None = None


class BackendError(RuntimeError):
    """The backend gave no usable answer (unreachable, timed out, HTTP error, unparseable response).

    The agent retries a bounded number of times, then ends the agent step with this error in the
    transcript; the controller keeps its last valid specification.
    """


class Backend(Protocol):
    name: str
    reads_situation: bool
    """Whether its answers use ``Message.context`` (a language model does; the rule-based one reads only the
    message): the agent reads the situation over MCP only for backends that use it."""

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        """The next agent message for ``history`` (which ends with a user message or tool results)."""
        ...

    async def aclose(self) -> None:
        """Release connections."""
        ...
