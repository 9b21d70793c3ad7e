"""The agent: message history, backends (rule-based stand-in, OpenAI-compatible LLM), MCP client loop."""

from agentic_mpc.agent.agent import Agent, AgentConfig, AgentError, StepReport, system_prompt
from agentic_mpc.agent.messages import Message, MessageHistory, ToolCall
from agentic_mpc.agent.observations import EmergencyWatch, EmergencyWatchConfig

__all__ = [
    "Agent",
    "AgentConfig",
    "AgentError",
    "EmergencyWatch",
    "EmergencyWatchConfig",
    "Message",
    "MessageHistory",
    "StepReport",
    "ToolCall",
    "system_prompt",
]
