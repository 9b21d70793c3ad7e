"""The SDK's ``MCPServer`` with the project's checks around every tool call: the published schema, an optional
gate (the per-client rate limit over HTTP) and a hook that learns who made each call.

Used by :mod:`agentic_mpc.mcp.server`; :func:`caller_of` names the client of a request.
"""

# No `from __future__ import annotations`: kept like server.py, whose tool closures the SDK reads at runtime.
import logging
from collections.abc import Callable
from typing import Any

from mcp.server.mcpserver import MCPServer
from mcp.server.mcpserver.exceptions import ToolError
from mcp.server.mcpserver.tools import Tool
from mcp_types import CallToolResult

from agentic_mpc.mcp.protocol import APPLY_AT_META_KEY, validate_arguments

logger = logging.getLogger(__name__)

__all__ = ["ControlServer", "ToolCallGate", "ToolCallHook", "caller_of"]

ToolCallHook = Callable[[dict[str, Any]], None]
"""Receives one dict per tool call the server received (see :meth:`ControlServer.call_tool`)."""
ToolCallGate = Callable[[dict[str, Any]], str | None]
"""Given the caller (:func:`caller_of`), a refusal message (the call is not run) or None (it runs)."""


class ControlServer(MCPServer):
    """``MCPServer`` that validates every call against the tool's published schema before running it.

    (The SDK validates with the pydantic model behind the tool, which ignores unknown arguments; the
    published schema refuses them, and refuses NaN, which JSON cannot carry but Python's parser accepts.)

    :attr:`tool_call_gate` (e.g. a per-client rate limit) may refuse a call before anything else happens: the
    caller gets a tool error and nothing is recorded. Every other call, accepted or refused, is reported to
    :attr:`on_tool_call` with the client that made it.
    """

    def __init__(self, *args: Any, tools: list[Tool], **kwargs: Any) -> None:
        super().__init__(*args, tools=tools, **kwargs)
        self.input_schemas = {tool.name: tool.parameters for tool in tools}
        self.on_tool_call: ToolCallHook | None = None
        self.tool_call_gate: ToolCallGate | None = None

    async def call_tool(self, name: str, arguments: dict[str, Any], context: Any = None) -> Any:
        caller = caller_of(context)
        if self.tool_call_gate is not None and (refusal := self.tool_call_gate(caller)) is not None:
            raise ToolError(refusal)
        record: dict[str, Any] = {"tool": name, "arguments": arguments, "ok": False, "error": None, "result": None,
                                  "apply_at_s": _apply_at(context), **caller}
        try:
            schema = self.input_schemas.get(name)
            if schema is not None:
                try:
                    validate_arguments(name, schema, arguments)
                except ValueError as error:
                    logger.warning("refused call %s(%r): %s", name, arguments, error)
                    raise ToolError(str(error)) from None
            result = await super().call_tool(name, arguments, context)
        except Exception as error:
            record["error"] = str(error)[:500]
            self._report(record)
            raise
        if isinstance(result, CallToolResult) and result.is_error:
            record["error"] = " ".join(getattr(c, "text", "") for c in result.content)[:500]
        else:
            record["ok"] = True
            structured = getattr(result, "structured_content", None)
            if isinstance(structured, dict):
                record["result"] = {k: v for k, v in structured.items() if k not in ("attached", "arguments", "tool")}
        self._report(record)
        return result

    def _report(self, record: dict[str, Any]) -> None:
        if self.on_tool_call is None:
            return
        try:
            self.on_tool_call(record)
        except Exception:  # recording must never fail a call
            logger.exception("the tool-call hook raised")


def caller_of(context: Any) -> dict[str, Any]:
    """Who made a request: ``client`` (the name/version from the client's ``initialize``), ``session`` (the
    MCP session id over HTTP) and ``address`` (the remote address over HTTP); None where unknown."""
    caller: dict[str, Any] = {"client": None, "session": None, "address": None}
    try:
        request_context = context.request_context
    except Exception:  # noqa: BLE001 - no request (a direct call): nobody to name
        return caller
    try:
        info = request_context.session.client_params.client_info
        caller["client"] = f"{info.name}/{info.version}" if info.version else str(info.name)
    except AttributeError:
        pass
    request = request_context.request
    headers = getattr(request, "headers", None)
    if headers is not None:
        caller["session"] = headers.get("mcp-session-id")
    remote = getattr(request, "client", None)
    if remote is not None:
        caller["address"] = getattr(remote, "host", None)
    return caller


def _apply_at(context: Any) -> Any:
    try:
        return (context.request_context.meta or {}).get(APPLY_AT_META_KEY)
    except Exception:  # noqa: BLE001 - no request, no metadata
        return None
