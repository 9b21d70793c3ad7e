"""The agent's state: the message history H(tau) = [m(0), ..., m(tau)] of the paper's section "Agent".

Four kinds of message, as in the paper: the system message (instructions, the initially attached primitives,
the tools), user messages (typed by a person, generated from observations, ``source="observation"``, or
the agent's own restore reminder, ``source="agent"``),
agent messages (text and tool invocation requests; role ``assistant`` as chat APIs call it) and tool results.
Every appended message is one agent step: its ``tau`` is its index in the history. (The paper numbers only
the messages it shows; here tool results and the agent's closing text are steps too.)

Messages are immutable; ``to_openai()`` gives the chat-completions wire form.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass, field, replace
from typing import Any, Literal

Role = Literal["system", "user", "assistant", "tool"]
Source = Literal["user", "observation", "agent"]


@dataclass(frozen=True, slots=True)
class ToolCall:
    """A tool invocation request from the agent.

    ``arguments`` is None when the backend's raw arguments were not a JSON object; ``error`` then says why,
    and the agent answers the call with a tool error instead of invoking anything.
    """

    id: str
    name: str
    arguments: dict[str, Any] | None
    raw_arguments: str = ""
    error: str | None = None

    @classmethod
    def of(cls, id: str, name: str, arguments: dict[str, Any]) -> ToolCall:
        return cls(id, name, dict(arguments), json.dumps(arguments))

    def describe(self) -> dict[str, Any]:
        described: dict[str, Any] = {"id": self.id, "tool": self.name, "arguments": self.arguments}
        if self.error is not None:
            described["raw_arguments"] = self.raw_arguments
            described["error"] = self.error
        return described


@dataclass(frozen=True, slots=True)
class Message:
    role: Role
    content: str = ""
    tool_calls: tuple[ToolCall, ...] = ()
    tool_call_id: str | None = None
    """Tool results: the id of the call they answer."""
    name: str | None = None
    """Tool results: the tool's name."""
    is_error: bool = False
    """Tool results: the call was refused or failed."""
    source: Source | None = None
    """User messages: typed by a person, generated from an observation, or the agent's own note to the model
    (``agent``: the restore reminder)."""
    data: dict[str, Any] | None = None
    """Structured payload beside the text: the system message's initial specification and tools, a tool
    result's structured content. Backends that are not language models (the rule-based one) read it."""
    tau: int = -1
    sim_time_s: float | None = None
    context: str | None = None
    """User messages: the situation when the step began, as the agent read it from MCP resources
    (:mod:`agentic_mpc.agent.situation`); a language model sees it before the message itself."""

    def to_openai(self) -> dict[str, Any]:
        """The chat-completions form of this message."""
        if self.role == "assistant":
            out: dict[str, Any] = {"role": "assistant", "content": self.content or None}
            if self.tool_calls:
                out["tool_calls"] = [
                    {
                        "id": call.id,
                        "type": "function",
                        # A call whose arguments did not parse is echoed with "{}": some servers refuse
                        # invalid JSON here; the tool error that answers it quotes the raw text.
                        "function": {
                            "name": call.name,
                            "arguments": call.raw_arguments if call.arguments is not None and call.raw_arguments
                            else "{}",
                        },
                    }
                    for call in self.tool_calls
                ]
            return out
        if self.role == "tool":
            return {"role": "tool", "tool_call_id": self.tool_call_id or "", "content": self.content}
        if self.role == "user" and self.context:
            said = self.content if self.source == "observation" else f"Passenger: {self.content}"
            return {"role": "user", "content": f"{self.context}\n\n{said}"}
        return {"role": self.role, "content": self.content}

    def describe(self) -> dict[str, Any]:
        """JSON-ready form for the transcript."""
        described: dict[str, Any] = {"tau": self.tau, "role": self.role, "content": self.content}
        if self.source is not None:
            described["source"] = self.source
        if self.context:
            described["context"] = self.context
        if self.tool_calls:
            described["tool_calls"] = [call.describe() for call in self.tool_calls]
        if self.role == "tool":
            described.update(tool_call_id=self.tool_call_id, tool=self.name, is_error=self.is_error)
        if self.sim_time_s is not None:
            described["sim_time_s"] = self.sim_time_s
        return described


@dataclass
class MessageHistory:
    """Append-only, thread-safe history; ``append`` stamps tau."""

    _messages: list[Message] = field(default_factory=list)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def append(self, message: Message) -> Message:
        with self._lock:
            stamped = replace(message, tau=len(self._messages))
            self._messages.append(stamped)
            return stamped

    @property
    def messages(self) -> tuple[Message, ...]:
        with self._lock:
            return tuple(self._messages)

    @property
    def tau(self) -> int:
        """The current agent step (index of the last message), -1 when empty."""
        return len(self._messages) - 1

    def __len__(self) -> int:
        return len(self._messages)

    def to_openai(self) -> list[dict[str, Any]]:
        return [m.to_openai() for m in self.messages]
