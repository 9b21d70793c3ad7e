"""Agent backends: ``rules`` (offline, deterministic, not an LLM), ``openai`` (any OpenAI-compatible
chat-completions endpoint: Ollama, vLLM, llama.cpp server, LM Studio, OpenAI) and ``llamacpp`` (a GGUF model
in this process through ``xllamacpp``, the optional extra ``agentic-mpc[llm]``). See docs/llm-backends.md."""

from __future__ import annotations

from typing import Any

from agentic_mpc.agent.backends.base import Backend, BackendError, BackendReply, ToolSpec

BACKENDS = ("rules", "openai", "llamacpp")


def make_backend(name: str, **options: Any) -> Backend:
    """A backend by name; ``options`` go to its constructor (``OpenAIConfig`` fields for ``openai``,
    ``LlamaCppConfig`` fields for ``llamacpp``: it checks and loads the model file now, and raises
    ``ModelFileError``, a ``ValueError``, if it is missing or not GGUF)."""
    if name == "rules":
        from agentic_mpc.agent.backends.rules import RulesBackend

        return RulesBackend(**options)
    if name == "openai":
        from agentic_mpc.agent.backends.openai import OpenAIBackend, OpenAIConfig

        return OpenAIBackend(OpenAIConfig(**options))
    if name == "llamacpp":
        from agentic_mpc.agent.backends.llamacpp import LlamaCppBackend, LlamaCppConfig

        return LlamaCppBackend(LlamaCppConfig(**options))
    raise ValueError(f"unknown backend {name!r} (choose from {', '.join(BACKENDS)})")


__all__ = ["BACKENDS", "Backend", "BackendError", "BackendReply", "ToolSpec", "make_backend"]
