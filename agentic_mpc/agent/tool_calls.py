"""Running the agent's tool calls: each call checked against the listed tools and their schemas, sent to the
MCP server, and answered with a tool message (a result, or an error the model can act on), recorded in the
transcript (``tool_call`` before it is sent, ``tool_result`` after).

What a language model reads of a controller tool's result is one line (:func:`result_line`): the call,
whether it applied, and how the specification now differs from the initial one. The whole result (every
attached primitive, about 600 tokens) stays in the message's ``data`` and the transcript's ``tool_result``: a
model would read it again after every call, seconds of prompt processing each on a CPU. (The rule-based
backend reads ``data``; its messages keep the server's text.)

:class:`ToolRunner` knows the MCP client contract (:mod:`agentic_mpc.mcp.protocol`) and the transcript, not
the agent: the agent (:mod:`agentic_mpc.agent.agent`) uses it, never the other way round.
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import Callable, Sequence
from typing import Any

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.messages import Message, ToolCall
from agentic_mpc.agent.prompt import shown_value, specification_changes
from agentic_mpc.agent.transcript import Transcript
from agentic_mpc.mcp.protocol import APPLY_AT_META_KEY, validate_arguments

logger = logging.getLogger("agentic_mpc.agent.agent")  # the agent's log, as before the split
Clock = Callable[[], float | None]


def call_key(call: ToolCall) -> str:
    """What identifies a call within a step (tool and arguments), to stop a model that repeats one."""
    return f"{call.name}:{json.dumps(call.arguments, sort_keys=True, default=str)}"


def result_line(call: ToolCall, data: Any, initial: dict[str, Any] | None) -> str | None:
    """A controller tool's result in one line for the model (see the module docstring); None for a result
    that is not a specification (another server's tool) or when the initial specification is unknown."""
    if not isinstance(data, dict) or not isinstance(data.get("attached"), list) or not isinstance(initial, dict):
        return None
    arguments = ", ".join(f"{key}={shown_value(value)}" for key, value in (call.arguments or {}).items())
    if data.get("applied", True):
        done = "applied" + (" (it changed nothing)" if data.get("changed") is False else "")
    else:
        done = f"accepted, takes effect at t={shown_value(data.get('apply_at_s'))} s"
    changes = specification_changes(initial, data)
    now = ("the specification is the initial one." if not changes
           else "differences from the initial specification: " + "; ".join(changes) + ".")
    return f"{call.name}({arguments}) {done}; {now}"


class ToolRunner:
    """Validates tool calls and sends them to the MCP server; ``now()`` (given per call: the step's clock)
    stamps the sim time of what it records. ``initial``: the initial specification (for :func:`result_line`)."""

    def __init__(self, transcript: Transcript, timeout_s: float) -> None:
        self.transcript = transcript
        self.timeout_s = timeout_s
        self.initial: dict[str, Any] | None = None

    @staticmethod
    def refuse(call: ToolCall, error: str, now: Clock) -> Message:
        """The tool error answering ``call`` (nothing was sent)."""
        logger.warning("tool call %s refused: %s", call.name, error)
        return Message("tool", f"Error: {error}", tool_call_id=call.id, name=call.name, is_error=True,
                       sim_time_s=now())

    async def execute(self, client: Any, tools: Sequence[ToolSpec], call: ToolCall, apply_at: float | None,
                      tau: int, now: Clock) -> Message:
        """Validate one call against the listed tools and schemas, then send it to the MCP server."""
        self.transcript.record("tool_call", tau=tau, sim_time_s=now(), tool=call.name,
                               arguments=call.arguments, raw_arguments=call.raw_arguments or None,
                               apply_at_s=apply_at)
        listed = {t.name: t for t in tools}
        if call.error is not None:
            return self._recorded(call, self.refuse(call, call.error, now), tau)
        if call.name not in listed:
            error = f"unknown tool {call.name!r}; available tools: {', '.join(sorted(listed))}"
            return self._recorded(call, self.refuse(call, error, now), tau)
        try:
            validate_arguments(call.name, listed[call.name].input_schema, call.arguments)
        except ValueError as error:
            return self._recorded(call, self.refuse(call, str(error), now), tau)
        assert client is not None
        meta = {APPLY_AT_META_KEY: apply_at} if apply_at is not None else None
        try:
            sent = client.call_tool(call.name, call.arguments, meta=meta)
            result = await asyncio.wait_for(sent, self.timeout_s)
        except Exception as error:  # protocol error, timeout, lost connection
            detail = str(error) or type(error).__name__
            return self._recorded(call, self.refuse(call, f"MCP call failed: {detail}", now), tau)
        text = "\n".join(getattr(block, "text", "") for block in result.content) or "(no content)"
        if result.is_error:
            return self._recorded(call, self.refuse(call, text, now), tau)
        text = result_line(call, result.structured_content, self.initial) or text
        message = Message("tool", text, tool_call_id=call.id, name=call.name, data=result.structured_content,
                          sim_time_s=now())
        logger.info("tool call %s(%s) applied%s", call.name, call.arguments,
                    f" at t={apply_at:.3f} s" if apply_at is not None else "")
        return self._recorded(call, message, tau)

    def _recorded(self, call: ToolCall, message: Message, tau: int) -> Message:
        outcome = {"error": message.content} if message.is_error else {"result": message.data or message.content}
        self.transcript.record(
            "tool_result", tau=tau, sim_time_s=message.sim_time_s, tool=call.name, arguments=call.arguments,
            is_error=message.is_error, **outcome,
        )
        return message
