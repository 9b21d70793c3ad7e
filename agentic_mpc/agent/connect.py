"""What the agent's ``mcp.Client`` connects to, and how it introduces itself."""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from mcp_types import Implementation

from agentic_mpc import __version__

CLIENT_INFO = Implementation(name="agentic-mpc-agent", version=__version__)
"""How the agent introduces itself to the MCP server (the ``client`` of its calls in ``events.csv``)."""


def mcp_target(server: Any, headers: Mapping[str, str], bearer_token_env: str | None) -> Any:
    """``server`` itself, or for a URL with ``headers`` or a bearer token (read from the environment variable
    ``bearer_token_env`` now, never stored), a streamable HTTP transport that sends them."""
    sent = dict(headers)
    if bearer_token_env:
        token = os.environ.get(bearer_token_env, "").strip()
        if not token:
            raise RuntimeError(f"the environment variable {bearer_token_env} holds no token")
        sent["Authorization"] = f"Bearer {token}"
    if not sent:
        return server
    if not isinstance(server, str):
        raise TypeError("HTTP headers and a bearer token apply only to a server given by URL")
    from mcp.client.streamable_http import streamable_http_client
    from mcp.shared._httpx_utils import create_mcp_http_client

    return streamable_http_client(server, http_client=create_mcp_http_client(headers=sent))
