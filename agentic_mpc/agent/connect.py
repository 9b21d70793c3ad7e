"""What the agent's ``mcp.Client`` connects to, how it introduces itself, and how it reads a JSON resource."""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Mapping
from typing import Any

from mcp_types import Implementation

from agentic_mpc import __version__

logger = logging.getLogger(__name__)

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


async def read_json_resource(client: Any, uri: str, missing: int = logging.WARNING) -> dict[str, Any] | None:
    """The JSON object the MCP resource ``uri`` holds, or None (logged at level ``missing``) if the server
    has no such resource or its content is not a JSON object: an older server still works without it."""
    try:
        read = await client.read_resource(uri)
        value = json.loads(read.contents[0].text)
    except Exception as error:  # noqa: BLE001 - any failure means "not available"
        logger.log(missing, "could not read %s: %s", uri, error)
        return None
    if not isinstance(value, dict):
        logger.log(missing, "%s is not a JSON object", uri)
        return None
    return value
