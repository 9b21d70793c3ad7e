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
class BackendReply:
    """An agent message: text and tool invocation requests (possibly none)."""

    text: str
    tool_calls: tuple[ToolCall, ...] = ()


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
