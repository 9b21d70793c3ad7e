"""How the agent runs, said once: the settings every agent has, whatever answers it (:class:`AgentOptions`,
:class:`AgentRunSettings` of a scenario's ``agent:``), :class:`AgentConfig` for the agent's own loop, and the
small checks it makes on what it is given.

This module imports no backend: each backend's settings class extends :class:`AgentRunSettings` beside the
backend (``agent/backends/rules.py``, ``chat.py``, ``openai.py``, ``llamacpp.py``), and
:mod:`agentic_mpc.agent.settings` assembles them into the union a scenario chooses from.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from agentic_mpc.agent.memory import MemorySettings
from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.world import ALERT_DISTANCE_M


class McpServerSettings(FrozenConfig):
    """Another MCP server the agent connects to besides the controller's (knowledge, a document store, ...)."""

    name: str = Field(..., pattern=r"^[a-z][a-z0-9_]{0,30}$", description="its tools are named <name>__<tool>")
    command: tuple[str, ...] | None = Field(None, min_length=1, description="start it: the command and arguments (stdio)")
    url: str | None = Field(None, pattern=r"^https?://", description="or reach it: its streamable HTTP URL")
    bearer_token_env: str | None = Field(None, description="HTTP: the environment variable holding its token")

    @model_validator(mode="after")
    def _one_way_to_reach_it(self) -> McpServerSettings:
        if (self.command is None) == (self.url is None):
            raise ValueError("give exactly one of command (stdio) or url (HTTP)")
        if "__" in self.name:
            raise ValueError("a server name may not contain '__' (it separates the server from its tool)")
        return self


class AgentOptions(FrozenConfig):
    """What every agent reads, whatever answers it."""

    mcp_servers: tuple[McpServerSettings, ...] = Field(
        (), description="other MCP servers the agent is a host of (their tools namespaced, read-only to the car)")
    knowledge: bool = Field(True, description="also connect the shipped knowledge server (traffic rules, the car's "
                                              "manual: docs/knowledge.md), in process, as 'knowledge' (false: only "
                                              "the controller's server and mcp_servers)")

    mode: Literal["lockstep", "realtime"] = Field(
        "lockstep", description="lockstep: reproducible, tool calls take effect latency_s (sim time) after the "
                                "message; realtime: they apply when they arrive, the car never waits")
    latency_s: float = Field(0.5, ge=0, description="lockstep: the thinking time charged to every agent step")
    observation_messages: bool = Field(False, description="wake the agent when an emergency vehicle approaches "
                                                          "or has passed (the run's events, read from "
                                                          "sumo://emergency-vehicles)")
    max_rounds_per_step: int = Field(6, ge=1, le=100, description="backend answers per agent step (a model that "
                                     "keeps calling tools is stopped there)")
    step_budget_s: float | None = Field(
        60.0, gt=0, description="wall seconds an agent step may take (null: no limit); when they run out the "
                                "step ends (\"budget\"), the car keeps its last valid specification")
    step_budget_tokens: int | None = Field(
        4096, ge=1, description="model tokens (prompt processed + generated, as the model's server reports them) "
                                "an agent step may spend (null: no limit)")
    warm_up: bool = Field(True, description="language models: have the model read the system message as soon as "
                                            "the agent starts, so that the first message pays only for itself")
    extra_prompt: str = Field("", max_length=8000, description="appended to the system prompt (language models)")
    memory: MemorySettings | None = Field(
        None, description="remember this passenger across runs: {profile: NAME, file: PATH, on_error: fail|ignore} "
                          "(agent/memory.py; docs/llm-backends.md, Memory); null: no memory")
    retrieval: bool = Field(True, description="language models: the knowledge passages that bear on a message "
                                              "and the situation go into its context, cited (agent/retrieval.py)")
    restore_reminder: bool = Field(
        False, description="language models: a step whose answer calls no tool while the specification differs "
                           "from the initial one gets one reminder round saying how it differs")


class AgentRunSettings(AgentOptions):
    """A scenario's ``agent:`` without its backend's own options: what the agent reads, and what the run
    reads for it. A backend's settings class extends this with a ``backend`` literal and
    ``build_backend(lefthand)``."""

    alert_distance_m: float = Field(ALERT_DISTANCE_M, gt=0,
                                    description="how far behind an emergency vehicle starts to matter (the run's "
                                                "one emergency detector: message timeline and observation messages)")

    def agent_config(self, **runtime: Any) -> AgentConfig:
        """The agent's configuration: these settings plus ``runtime`` (transcript path, retries, ...)."""
        shared = {name: getattr(self, name) for name in AgentOptions.model_fields}
        return AgentConfig(**{**shared, **runtime})


class AgentConfig(AgentOptions):
    """How the agent runs: what every agent reads (:class:`AgentOptions`, from a scenario or the command line:
    :meth:`AgentRunSettings.agent_config`) and what only the agent's own loop needs."""

    mode: Literal["lockstep", "realtime"] = Field(
        "realtime", description="an Agent used on its own answers as messages come; a run's agent takes the "
                                "scenario's mode (lockstep unless it says otherwise)")
    max_tool_calls_per_round: int = Field(8, ge=1, le=100)
    max_consecutive_errors: int = Field(3, ge=1, description="rounds in a row whose every tool call failed")
    backend_attempts: int = Field(3, ge=1, le=20, description="tries per backend answer before the step ends")
    backend_timeout_s: float = Field(125.0, gt=0, description="one backend answer, at most (a language model's "
                                                               "settings: its timeout_s + 5 s)")
    warm_up_timeout_s: float = Field(600.0, gt=0, description="reading the system message once at the start, at "
                                     "most (a native-mode prompt of ~2900 tokens takes ~2 min on one thread)")
    retry_backoff_s: float = Field(0.5, ge=0)
    tool_timeout_s: float = Field(10.0, gt=0)
    max_message_chars: int = Field(4000, ge=1)
    startup_timeout_s: float = Field(60.0, gt=0)
    lockstep_timeout_s: float = Field(600.0, gt=0)
    transcript_path: Path | None = None
    headers: dict[str, str] = Field(default_factory=dict, repr=False,
                                    description="HTTP (a URL server): extra request headers, e.g. Authorization")
    bearer_token_env: str | None = Field(
        None, description="HTTP: the environment variable holding the server's bearer token (sent as "
                          "'Authorization: Bearer ...'; read when the agent connects, never stored)")
    situation: bool = Field(True, description="give each step the current situation read from MCP resources "
                                              "(backends that read it: the language models)")


@dataclass(frozen=True)
class WatchRequest:
    """A queue item: check ``sumo://emergency-vehicles`` (lockstep: at ``sim_time_s``)."""

    sim_time_s: float | None


class AgentError(RuntimeError):
    """The agent could not start (no MCP server, no tools)."""


def root_cause(error: BaseException) -> BaseException:
    """The first leaf of nested exception groups (task groups wrap the interesting error)."""
    while isinstance(error, BaseExceptionGroup) and error.exceptions:
        error = error.exceptions[0]
    return error


def check_message(text: Any, limit: int) -> str | None:
    """Why ``text`` cannot become a user message, or None."""
    if not isinstance(text, str):
        return f"a message must be text, got {type(text).__name__}"
    if not text.strip():
        return "empty message"
    if len(text) > limit:
        return f"message of {len(text)} characters exceeds the limit of {limit}"
    return None
