"""The agent: message history, backends (rule-based stand-in, OpenAI-compatible LLM), MCP client loop.

Names are imported on first use (the MCP client is a heavy import): ``from agentic_mpc.agent import Agent``.
"""

from importlib import import_module
from typing import Any

_EXPORTS = {
    "Agent": "agentic_mpc.agent.agent",
    "AgentConfig": "agentic_mpc.agent.config",
    "AgentError": "agentic_mpc.agent.config",
    "StepReport": "agentic_mpc.agent.report",
    "system_prompt": "agentic_mpc.agent.prompt",
    "Message": "agentic_mpc.agent.messages",
    "MessageHistory": "agentic_mpc.agent.messages",
    "ToolCall": "agentic_mpc.agent.messages",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'agentic_mpc.agent' has no attribute {name!r}")
    return getattr(import_module(_EXPORTS[name]), name)
