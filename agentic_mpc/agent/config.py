"""How the agent runs (:class:`AgentConfig`), and the small checks it makes on what it is given."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field


class AgentConfig(BaseModel):
    """How the agent runs."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    timing: Literal["realtime", "lockstep"] = "realtime"
    latency_s: float = Field(1.0, ge=0, description="lockstep: the thinking time charged to every agent step")
    max_rounds_per_step: int = Field(6, ge=1, le=100, description="backend answers per agent step")
    max_tool_calls_per_round: int = Field(8, ge=1, le=100)
    max_consecutive_errors: int = Field(3, ge=1, description="rounds in a row whose every tool call failed")
    backend_attempts: int = Field(3, ge=1, le=20, description="tries per backend answer before the step ends")
    backend_timeout_s: float = Field(120.0, gt=0)
    retry_backoff_s: float = Field(0.5, ge=0)
    tool_timeout_s: float = Field(10.0, gt=0)
    max_message_chars: int = Field(4000, ge=1)
    startup_timeout_s: float = Field(60.0, gt=0)
    lockstep_timeout_s: float = Field(600.0, gt=0)
    transcript_path: Path | None = None
    system_prompt_extra: str = ""
    headers: dict[str, str] = Field(default_factory=dict, repr=False,
                                    description="HTTP (a URL server): extra request headers, e.g. Authorization")
    bearer_token_env: str | None = Field(
        None, description="HTTP: the environment variable holding the server's bearer token (sent as "
                          "'Authorization: Bearer ...'; read when the agent connects, never stored)")
    situation: bool = Field(True, description="give each step the current situation read from MCP resources "
                                              "(backends that read it: the language models)")
    restore_reminder: bool = Field(
        False, description="a step whose answer calls no tool while the specification differs from the initial one "
                          "gets one more round: that answer is set aside (transcript event restore_reminder), a "
                          "note says how the specification differs and asks the model to restore it if the "
                          "situation that needed the change is over, else to reply (once a step; backends that "
                          "read the situation: the language models)")
    watch_emergency_vehicles: bool = Field(
        False, description="wake on an emergency vehicle approaching / passed, detected on sumo://emergency-"
                           "vehicles (realtime: subscribed to its updates; lockstep: checked at watch())")
    alert_distance_m: float = Field(80.0, gt=0, description="the watch: how far behind an emergency vehicle matters")


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
