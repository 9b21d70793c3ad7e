"""The agent's settings, said once: what a scenario's ``agent:`` holds, what ``ask``, ``serve`` and
``eval-agent`` build from their flags, and what the run loop and the agent read.

:data:`AgentSettings` is a union discriminated by ``backend`` (``rules``, ``openai``, ``llamacpp``): the
settings every agent has (:class:`AgentRunSettings`: timing, latency, observation messages, rounds per step,
...) plus its backend's own options, each with its one default. A YAML mapping stays flat
(``{backend: llamacpp, model: qwen.gguf, threads: 1}``); a key another backend has is an error naming it.
:meth:`build_backend` makes the backend, :meth:`agent_config` the agent's :class:`AgentConfig`.

Imports point one way: this module assembles the registry from the backends' modules, where each settings
class lives beside its backend (agent/backends/rules.py, chat.py, openai.py, llamacpp.py); they and the shared
base (agent/config.py) import nothing of this module.
"""

from __future__ import annotations

from typing import Annotated, Any, Union

from pydantic import Field, TypeAdapter

from agentic_mpc.agent.backends.chat import ChatSettings
from agentic_mpc.agent.backends.llamacpp import LlamaCppSettings
from agentic_mpc.agent.backends.openai import OpenAISettings
from agentic_mpc.agent.backends.rules import RulesSettings, Side
from agentic_mpc.agent.backends.structured import ToolMode
from agentic_mpc.agent.config import AgentRunSettings, McpServerSettings

__all__ = [
    "BACKENDS", "BACKEND_SETTINGS", "AgentRunSettings", "AgentSettings", "ChatSettings", "LlamaCppSettings",
    "McpServerSettings", "OpenAISettings", "RulesSettings", "Side", "ToolMode", "agent_settings",
    "register_backend", "unregister_backend", "with_backend",
]

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
