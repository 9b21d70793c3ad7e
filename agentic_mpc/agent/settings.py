"""The agent's settings, said once: what a scenario's ``agent:`` holds, what ``ask``, ``serve`` and
``eval-agent`` build from their flags, and what the run loop and the agent read.

:data:`AgentSettings` is a union discriminated by ``backend`` (``rules``, ``openai``, ``llamacpp``): the
settings every agent has (:class:`AgentRunSettings`: timing, latency, observation messages, rounds per step,
...) plus its backend's own options, each with its one default. A YAML mapping stays flat
(``{backend: llamacpp, model: qwen.gguf, threads: 1}``); a key another backend has is an error naming it.
:meth:`build_backend` makes the backend, :meth:`agent_config` the agent's :class:`AgentConfig`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import Field, TypeAdapter, field_validator, model_validator

from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.world import ALERT_DISTANCE_M

ToolMode = Literal["native", "json_schema"]
Side = Literal["left", "right"]


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


class AgentRunSettings(FrozenConfig):
    """What every agent has, whatever answers it."""

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
                                                          "or has passed (read from sumo://emergency-vehicles)")
    alert_distance_m: float = Field(ALERT_DISTANCE_M, gt=0,
                                    description="how far behind an emergency vehicle starts to matter")
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
    restore_reminder: bool = Field(
        False, description="language models: a step whose answer calls no tool while the specification differs "
                           "from the initial one gets one reminder round saying how it differs")

    def agent_config(self, **runtime: Any) -> Any:  # -> AgentConfig
        """The agent's configuration: these settings plus ``runtime`` (transcript path, retries, ...)."""
        from agentic_mpc.agent.config import AgentConfig

        shared = {name: getattr(self, name) for name in AgentRunSettings.model_fields}
        if isinstance(self, ChatSettings):
            runtime.setdefault("backend_timeout_s", self.timeout_s + 5.0)  # the backend's own timeout runs out first
        return AgentConfig(**{**shared, **runtime})


class RulesSettings(AgentRunSettings):
    """The offline rule-based stand-in (deterministic, English; not a language model)."""

    backend: Literal["rules"] = "rules"
    yield_lane: Side | None = Field(None, description="where to pull over for emergency vehicles (default: the "
                                                      "road edge: left in left-hand traffic)")

    def build_backend(self, lefthand: bool) -> Any:
        from agentic_mpc.agent.backends.rules import RulesBackend

        return RulesBackend(yield_lane=self.yield_lane or ("left" if lefthand else "right"))


class ChatSettings(AgentRunSettings):
    """What both language-model backends have."""

    DEFAULT_TOOL_MODE: ClassVar[ToolMode] = "native"
    tool_mode: ToolMode | None = Field(
        None, description="native tool calls, or the answer constrained to one call or a reply by a JSON schema "
                          "of the tools (default: native for openai, json_schema for llamacpp)")
    temperature: float = Field(0.0, ge=0, le=2, description="sampling temperature")
    max_tokens: int = Field(512, ge=1, le=32768, description="tokens per answer")
    extra_body: dict[str, Any] = Field(default_factory=dict, description="merged into every request body "
                                                                         "(e.g. top_p)")
    timeout_s: float = Field(120.0, gt=0, description="seconds per answer; the agent step's own timeout is this "
                                                      "plus 5 s, so the backend's runs out first")
    context_tokens: int | None = Field(
        None, ge=256, description="the model's context in tokens: older steps of the history are left out of a "
                                  "request that would not fit (null: never; llamacpp: its ctx_size)")
    rules_first: bool = Field(False, description="the rules backend answers what it understands, the model the "
                                                 "rest (agent/backends/rules_first.py)")

    def with_rules_first(self, model: Any, lefthand: bool) -> Any:
        """``model``, or the rules in front of it when ``rules_first`` is set."""
        if not self.rules_first:
            return model
        from agentic_mpc.agent.backends.rules import RulesBackend
        from agentic_mpc.agent.backends.rules_first import RulesFirst

        return RulesFirst(RulesBackend(yield_lane="left" if lefthand else "right"), model)

    @property
    def context_limit_tokens(self) -> int | None:
        """The history must fit into this many tokens (None: no limit known)."""
        return None if self.context_tokens is None else max(128, self.context_tokens - self.max_tokens)

    @property
    def effective_tool_mode(self) -> ToolMode:
        return self.tool_mode or self.DEFAULT_TOOL_MODE


class OpenAISettings(ChatSettings):
    """Any OpenAI-compatible chat-completions endpoint (Ollama, vLLM, llama.cpp's server, OpenAI)."""

    backend: Literal["openai"] = "openai"
    base_url: str = Field("http://localhost:11434/v1", description="the endpoint's /v1 URL (default Ollama's)")
    model: str = Field("granite4:micro", description="the model name")
    api_key_env: str | None = Field("OPENAI_API_KEY", description="environment variable holding the API key "
                                    "(sent as a bearer token when it is set; null: never)")

    def build_backend(self, lefthand: bool) -> Any:
        from agentic_mpc.agent.backends.openai import OpenAIBackend

        return self.with_rules_first(OpenAIBackend(self), lefthand)


class LlamaCppSettings(ChatSettings):
    """A GGUF model in this process through xllamacpp (the ``llm`` extra)."""

    DEFAULT_TOOL_MODE: ClassVar[ToolMode] = "json_schema"
    backend: Literal["llamacpp"] = "llamacpp"
    model: Path = Field(..., description="the GGUF model file")
    threads: int = Field(1, ge=1, le=256, description="CPU threads for generation and prompt processing")
    ctx_size: int = Field(8192, ge=256, le=1_048_576, description="context size in tokens")
    gpu_layers: int = Field(-1, ge=-1, description="layers offloaded to a GPU (-1: llama.cpp decides; 0: none)")
    verbose: bool = Field(False, description="llama.cpp's own log on stderr")
    rules_first: bool = Field(True, description="the rules backend answers what it understands, the model the "
                                                "rest (agent/backends/rules_first.py); on by default for a model "
                                                "in process, a small one on a CPU (docs/llm-backends.md: 111 of "
                                                "121 suite cases against 60 for Qwen2.5-Coder-1.5B alone)")

    @property
    def context_limit_tokens(self) -> int:
        """The history must fit into this many tokens: the context, less one answer."""
        return max(128, min(self.context_tokens or self.ctx_size, self.ctx_size) - self.max_tokens)

    @field_validator("model")
    @classmethod
    def _a_gguf_file(cls, model: Path) -> Path:
        """The file must be there before anything starts (said with the YAML path or the flag)."""
        from agentic_mpc.agent.backends.llamacpp import check_gguf  # light: no llama.cpp import

        return check_gguf(model)

    def build_backend(self, lefthand: bool) -> Any:
        from agentic_mpc.agent.backends.llamacpp import LlamaCppBackend

        return self.with_rules_first(LlamaCppBackend(self), lefthand)


BACKEND_SETTINGS: dict[str, type[AgentRunSettings]] = {}
"""Every backend's settings class by its ``backend`` name: a backend is its module and one
:func:`register_backend` of a settings class with a ``backend`` literal and ``build_backend(lefthand)``."""
_adapter: list[TypeAdapter[Any]] = []


def register_backend(settings_class: type[AgentRunSettings]) -> type[AgentRunSettings]:
    """Make ``settings_class`` a choice of ``backend`` (scenario files, ``--agent``, ``ask --backend``)."""
    name = settings_class.model_fields["backend"].default
    if name in BACKEND_SETTINGS and BACKEND_SETTINGS[name] is not settings_class:
        raise ValueError(f"a backend named {name!r} is registered already")
    BACKEND_SETTINGS[name] = settings_class
    _adapter.clear()
    return settings_class


def unregister_backend(name: str) -> None:
    """Remove a backend again (a test's toy one)."""
    BACKEND_SETTINGS.pop(name, None)
    _adapter.clear()


for _settings_class in (RulesSettings, OpenAISettings, LlamaCppSettings):
    register_backend(_settings_class)
BACKENDS = tuple(BACKEND_SETTINGS)
"""The built-in backends."""

AgentSettings = Any
"""One registered backend's settings (an instance of a :data:`BACKEND_SETTINGS` class), chosen by ``backend``."""


def agent_settings(data: dict[str, Any] | None = None, **updates: Any) -> Any:
    """Validate a flat mapping of settings as its ``backend``'s class (``rules`` when it names none);
    pydantic's ``ValidationError`` names the bad key (its location starts with the backend's name)."""
    merged = {**(data or {}), **updates}
    merged.setdefault("backend", "rules")
    if not _adapter:
        classes = tuple(BACKEND_SETTINGS.values())
        union = classes[0] if len(classes) == 1 else Annotated[Union[classes], Field(discriminator="backend")]
        _adapter.append(TypeAdapter(union))
    return _adapter[0].validate_python(merged)


def with_backend(settings: AgentRunSettings, backend: str) -> dict[str, Any]:
    """``settings`` as a mapping for another backend: the shared settings carried over, the old backend's
    own options dropped (they may not exist in the new one)."""
    data = settings.model_dump()
    if data.get("backend") == backend:
        return data
    return {**{name: data[name] for name in AgentRunSettings.model_fields}, "backend": backend}
