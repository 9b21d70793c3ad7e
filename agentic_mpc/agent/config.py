"""How the agent runs (:class:`AgentConfig`), and the small checks it makes on what it is given."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pydantic import Field

from agentic_mpc.agent.settings import AgentRunSettings


class AgentConfig(AgentRunSettings):
    """How the agent runs: the settings every agent has (:class:`AgentRunSettings`, from a scenario or the
    command line: :meth:`AgentRunSettings.agent_config`) and what only the agent's own loop needs."""

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
