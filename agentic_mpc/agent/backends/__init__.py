"""Agent backends: ``rules`` (offline, deterministic, not an LLM) and ``openai`` (any OpenAI-compatible
chat-completions endpoint with tool calling: Ollama, vLLM, llama.cpp server, LM Studio, OpenAI)."""

from __future__ import annotations

from typing import Any

from agentic_mpc.agent.backends.base import Backend, BackendError, BackendReply, ToolSpec

BACKENDS = ("rules", "openai")


def make_backend(name: str, **options: Any) -> Backend:
    """A backend by name; ``options`` go to its constructor (``OpenAIConfig`` fields for ``openai``)."""
    if name == "rules":
        from agentic_mpc.agent.backends.rules import RulesBackend

        return RulesBackend(**options)
    if name == "openai":
        from agentic_mpc.agent.backends.openai import OpenAIBackend, OpenAIConfig

        return OpenAIBackend(OpenAIConfig(**options))
    raise ValueError(f"unknown backend {name!r} (choose from {', '.join(BACKENDS)})")


__all__ = ["BACKENDS", "Backend", "BackendError", "BackendReply", "ToolSpec", "make_backend"]
