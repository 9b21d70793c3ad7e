"""What one agent step did: the message that started it, the tool calls, the last text, how it ended."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from agentic_mpc.agent.config import WatchRequest
from agentic_mpc.agent.messages import Source


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
    ended: Literal["idle", "backend_error", "gave_up", "round_limit", "repeated", "rejected", "closed"] = "idle"
    """``repeated``: the backend asked again for calls it had made in this step (a small model that sees no
    end to its task); they were not run again and the step ended."""

    @property
    def applied_calls(self) -> list[dict[str, Any]]:
        """The calls the server accepted, as {"tool", "arguments"}."""
        return [{"tool": c["tool"], "arguments": c["arguments"]} for c in self.tool_calls if c["ok"]]


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
