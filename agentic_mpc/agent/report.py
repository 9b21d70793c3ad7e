"""What one agent step did: the message that started it, the tool calls, the last text, how it ended."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, Literal

from agentic_mpc.agent.backend_calls import StepUsage
from agentic_mpc.agent.config import WatchRequest
from agentic_mpc.agent.messages import Message, Source, ToolCall

logger = logging.getLogger("agentic_mpc.agent.agent")  # the agent's step lines, where they always were


@dataclass
class StepReport:
    """What one agent step did."""

    message: str
    source: Source
    sim_time_s: float | None
    first_tau: int = -1
    last_tau: int = -1
    tool_calls: list[dict[str, Any]] = field(default_factory=list)
    """Each call: tool, arguments, ok, result or error, apply_at_s."""
    text: str = ""
    """The agent's last text."""
    errors: list[str] = field(default_factory=list)
    ended: Literal["idle", "backend_error", "gave_up", "round_limit", "repeated", "undone", "budget", "rejected",
                   "closed"] = "idle"
    """``repeated``: the backend asked again for calls it had made in this step (a small model that sees no
    end to its task); they were not run again and the step ended. ``undone``: a call put the specification
    back as it was before the call just made (a model going back and forth); the step ended there.
    ``budget``: the step's time or token budget ran out (agent/backend_calls.py)."""
    usage: StepUsage = field(default_factory=StepUsage)
    """What the step's answers cost the model (tokens, the model's own time)."""
    wall_s: float = 0.0
    """The step's wall time, from its message to its end."""

    def add_call(self, call: ToolCall, result: Message, apply_at_s: float | None) -> bool:
        """Record one call and the tool message answering it; whether the server accepted it."""
        entry: dict[str, Any] = {"tool": call.name, "arguments": call.arguments, "ok": not result.is_error}
        entry["error" if result.is_error else "result"] = result.data if result.data else result.content
        if apply_at_s is not None:
            entry["apply_at_s"] = apply_at_s
        self.tool_calls.append(entry)
        if result.is_error:
            self.errors.append(f"{call.name}: {result.content}")
        return not result.is_error

    @property
    def applied_calls(self) -> list[dict[str, Any]]:
        """The calls the server accepted, as {"tool", "arguments"}."""
        return [{"tool": c["tool"], "arguments": c["arguments"]} for c in self.tool_calls if c["ok"]]

    def close(self, transcript: Any, sim_time_s: float | None) -> None:
        """Say how the step ended: a log line (a warning unless it went idle) and the transcript's ``step_end``."""
        level = logging.INFO if self.ended == "idle" else logging.WARNING
        logger.log(level, "agent step tau %d-%d ended (%s): %d tool call(s), %d error(s)", self.first_tau,
                   self.last_tau, self.ended, len(self.tool_calls), len(self.errors))
        transcript.record("step_end", tau=self.last_tau, sim_time_s=sim_time_s, ended=self.ended,
                          applied=self.applied_calls, errors=self.errors, wall_s=self.wall_s, **self.usage.describe())


def attached_of(specification: Any) -> Any:
    """The attached primitives of a specification (``mpc://specification`` or a tool result), if it says."""
    return specification.get("attached") if isinstance(specification, dict) else None


def answer_closed(queue: Any) -> None:
    """Answer what is still queued when the agent closes (``asyncio.Queue`` of (message, future) or None):
    a message ends ``closed``, an emergency-vehicle check finds nothing; nobody is left waiting."""
    while queue is not None and not queue.empty():
        item = queue.get_nowait()
        if item is None:
            continue
        message, future = item
        if isinstance(message, WatchRequest):
            future.set_result([])
        else:
            future.set_result(StepReport(message.content, message.source or "user", message.sim_time_s, ended="closed"))
