"""Agent backends: ``rules`` (offline, deterministic, not an LLM), ``openai`` (any OpenAI-compatible
chat-completions endpoint: Ollama, vLLM, llama.cpp server, LM Studio, OpenAI) and ``llamacpp`` (a GGUF model
in this process through ``xllamacpp``, the optional extra ``agentic-mpc[llm]``). See docs/llm-backends.md."""

from __future__ import annotations

from typing import Any

from agentic_mpc.agent.backends.base import Backend, BackendError, BackendReply, ToolSpec


def __getattr__(name: str) -> Any:
    """``BACKENDS`` on first use: the registry (agent/settings.py) imports the backends' modules, so this
    package must load without it."""
    if name == "BACKENDS":
        from agentic_mpc.agent.settings import BACKENDS

        return BACKENDS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def make_backend(name: str, *, lefthand: bool = True, **options: Any) -> Backend:
    """A backend by name with ``options`` as its settings (``OpenAISettings`` fields for ``openai``,
    ``LlamaCppSettings`` for ``llamacpp``, each beside its backend; the latter checks and loads the model file
    now and raises ``ModelFileError``, a ``ValueError``, if it is missing or not GGUF). ``lefthand``: the road
    the rules backend pulls over on (its ``yield_lane`` default)."""
    from pydantic import ValidationError

    from agentic_mpc.agent.settings import BACKEND_SETTINGS, agent_settings

    if name not in BACKEND_SETTINGS:
        raise ValueError(f"unknown backend {name!r} (choose from {', '.join(BACKEND_SETTINGS)})")
    try:
        settings = agent_settings(options, backend=name)
    except ValidationError as error:  # the check's own error (ModelFileError, ...) where there is one
        first = error.errors()[0]
        cause = first.get("ctx", {}).get("error")
        raise cause if isinstance(cause, ValueError) else ValueError(f"{first['loc'][-1]}: {first['msg']}") from None
    return settings.build_backend(lefthand)


__all__ = ["BACKENDS", "Backend", "BackendError", "BackendReply", "ToolSpec", "make_backend"]
