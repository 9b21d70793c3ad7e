"""The agent as an MCP host of several servers: the controller's (its tools by their own names) and any
others (knowledge, a user's document store, a web search), each with its own session; their tools are
namespaced ``<server>__<tool>`` and every call goes to the server that listed it. Only the controller's
server holds the specification, so no other server's tool can change it.

A server that does not start, times out or lists no tools is left out with the reason (logged and in the
transcript as ``server_error``); the agent goes on with the ones that work.
"""

from __future__ import annotations

import asyncio
import logging
from contextlib import AsyncExitStack
from dataclasses import dataclass, field
from typing import Any

from mcp import Client, StdioServerParameters

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.connect import CLIENT_INFO, mcp_target

logger = logging.getLogger("agentic_mpc.agent.agent")
SEPARATOR = "__"
CONNECT_TIMEOUT_S = 30.0


def namespaced(server: str, tool: str) -> str:
    return f"{server}{SEPARATOR}{tool}"


def target_of(entry: Any) -> Any:
    """What ``mcp.Client`` connects to for a server entry of the settings (a command or a URL)."""
    if entry.command:
        return StdioServerParameters(command=entry.command[0], args=list(entry.command[1:]))
    return mcp_target(entry.url, {}, entry.bearer_token_env) if entry.bearer_token_env else entry.url


@dataclass
class ServerHost:
    """The controller's session and the others'; :meth:`call_tool` as ``mcp.Client`` has it."""

    control: Any
    others: dict[str, Any] = field(default_factory=dict)
    """server name -> its client session."""
    tools: tuple[ToolSpec, ...] = ()
    """Every other server's tools, namespaced."""
    errors: list[str] = field(default_factory=list)

    async def connect(self, stack: AsyncExitStack, servers: dict[str, Any]) -> None:
        """Open a session to each of ``servers`` (name -> anything ``mcp.Client`` takes) and list its tools."""
        listed: list[ToolSpec] = []
        for name, target in servers.items():
            try:  # asyncio.timeout, not wait_for: the session's task group must be entered in this task
                async with asyncio.timeout(CONNECT_TIMEOUT_S):
                    client = await stack.enter_async_context(Client(target, cache=None, client_info=CLIENT_INFO))
                    tools = (await client.list_tools()).tools
                if not tools:
                    raise RuntimeError("it lists no tools")
            except Exception as error:  # noqa: BLE001 - one server failing leaves the others
                reason = f"MCP server {name!r} left out: {type(error).__name__}: {error}"
                logger.warning(reason)
                self.errors.append(reason)
                continue
            self.others[name] = client
            listed += [ToolSpec(namespaced(name, t.name), f"[{name}] {t.description or ''}", dict(t.input_schema))
                       for t in tools]
        self.tools = tuple(listed)

    async def call_tool(self, name: str, arguments: dict[str, Any], meta: dict[str, Any] | None = None) -> Any:
        server, separator, tool = name.partition(SEPARATOR)
        if separator and server in self.others:
            return await self.others[server].call_tool(tool, arguments)  # no scheduling: they change no car
        return await self.control.call_tool(name, arguments, meta=meta)
