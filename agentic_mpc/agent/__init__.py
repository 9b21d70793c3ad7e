"""The agent: message history, backends (rule-based stand-in, OpenAI-compatible LLM), MCP client loop.

Names are imported on first use (the MCP client is a heavy import): ``from agentic_mpc.agent import Agent``.
"""

from agentic_mpc.lazy_exports import lazy_exports

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

__getattr__ = lazy_exports("agentic_mpc.agent", _EXPORTS)
