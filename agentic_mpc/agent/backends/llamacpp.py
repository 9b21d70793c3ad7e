"""A language model in this process: any GGUF file run by llama.cpp through ``xllamacpp``, no server to start.

``pip install "agentic-mpc[llm]"`` installs ``xllamacpp`` (prebuilt wheels, nothing to compile); it is
imported only when this backend is built. The model file is checked before anything runs (it must exist and
start with the GGUF magic) and loaded when the backend is built, so a bad path or file fails before the run
starts, with a clear error.

The requests are the same chat completions as the ``openai`` backend's
(:class:`~agentic_mpc.agent.backends.chat.ChatBackend`), handled by llama.cpp's own server code in process:
the model's chat template (jinja), and in the default ``tool_mode="json_schema"`` the answer constrained by
a grammar built from the MCP tools' schemas (one tool call or a short reply), so that even a small model
answers with something the agent can read. llama.cpp keeps the prompt's KV cache between calls: the system
message is read once, by the first call (seconds on one CPU thread), later calls pay only for what is new.

Use ``threads=1`` on a small machine shared with the simulation (two threads stalled for 15-60 s on two
cores). Answers are streamed from llama.cpp: when the agent abandons one (its ``backend_timeout_s``), the
generation stops at the next token (the prompt being read is finished first).
"""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import Any, ClassVar, Literal

from pydantic import Field, field_validator

from agentic_mpc.agent.backends.base import Backend, BackendError
from agentic_mpc.agent.backends.chat import ChatBackend, ChatSettings
from agentic_mpc.agent.backends.structured import ToolMode

GGUF_MAGIC = b"GGUF"
INSTALL_HINT = 'the llamacpp backend needs xllamacpp: pip install "agentic-mpc[llm]"'


class ModelFileError(ValueError):
    """The model file does not exist, cannot be read, or is not a GGUF file."""


def check_gguf(path: str | Path) -> Path:
    """``path``, if it is a readable GGUF file; else :class:`ModelFileError` saying what is wrong."""
    path = Path(path).expanduser()
    if not path.exists():
        raise ModelFileError(f"the model file {path} does not exist")
    if not path.is_file():
        raise ModelFileError(f"the model path {path} is not a file")
    try:
        with path.open("rb") as file:
            magic = file.read(4)
    except OSError as error:
        raise ModelFileError(f"the model file {path} cannot be read: {error}") from error
    if magic != GGUF_MAGIC:
        raise ModelFileError(f"{path} is not a GGUF model file (it starts with {magic!r}, not {GGUF_MAGIC!r})")
    return path


def _import_xllamacpp() -> Any:
    try:
        import xllamacpp
    except ImportError as error:
        raise ModuleNotFoundError(INSTALL_HINT) from error
    return xllamacpp


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
        return check_gguf(model)

    def build_backend(self, lefthand: bool) -> Backend:
        return self.with_rules_first(LlamaCppBackend(self), lefthand)


class LlamaCppBackend(ChatBackend):
    """A GGUF model in process (see the module docstring)."""

    name = "llamacpp"

    def __init__(self, config: LlamaCppSettings) -> None:
        super().__init__()
        self.config = config
        path = check_gguf(config.model)
        xlc = _import_xllamacpp()
        params = xlc.CommonParams()
        params.model.path = str(path)
        params.n_ctx = config.ctx_size
        params.n_parallel = 1
        params.n_gpu_layers = config.gpu_layers
        params.cpuparams.n_threads = config.threads
        params.cpuparams_batch.n_threads = config.threads
        params.use_jinja = True
        params.warmup = False
        if not config.verbose:
            params.verbosity = -1
        try:
            self._server: Any = xlc.Server(params)
        except Exception as error:
            raise ModelFileError(f"llama.cpp could not load {path}: {error}") from error
        self._lock = threading.Lock()

    def _handle(self, body: dict[str, Any], abandoned: threading.Event) -> dict[str, Any]:
        """Run one request, streamed so that it stops at the next token once ``abandoned`` is set."""
        chunks: list[dict[str, Any]] = []

        def on_chunk(chunk: dict[str, Any]) -> bool:
            chunks.append(chunk)
            return abandoned.is_set()  # True stops the generation

        with self._lock:
            if self._server is None:
                raise BackendError("the llamacpp backend is closed")
            try:
                self._server.handle_chat_completions({**body, "stream": True}, on_chunk)
            except Exception as error:  # llama.cpp refuses the request (a bad schema, ...)
                raise BackendError(f"llama.cpp refused the request: {error}") from error
        if abandoned.is_set():
            raise BackendError("the answer was abandoned")
        return assemble_stream(chunks)

    async def send(self, body: dict[str, Any]) -> dict[str, Any]:
        abandoned = threading.Event()
        try:
            return await asyncio.to_thread(self._handle, body, abandoned)
        except asyncio.CancelledError:  # the agent gave up on this answer (its timeout): stop generating it
            abandoned.set()
            raise

    def close(self) -> None:
        """Free the model (waits for a call still running)."""
        with self._lock:
            self._server = None

    async def aclose(self) -> None:
        await asyncio.to_thread(self.close)


def assemble_stream(chunks: list[dict[str, Any]]) -> dict[str, Any]:
    """Streamed chat-completion chunks to one chat completion; :class:`BackendError` for an error chunk."""
    content: list[str] = []
    calls: dict[int, dict[str, Any]] = {}
    finish = None
    timings = None
    for chunk in chunks:
        if not isinstance(chunk, dict) or "error" in chunk:
            error = chunk.get("error") if isinstance(chunk, dict) else chunk
            message = error.get("message", error) if isinstance(error, dict) else error
            raise BackendError(f"llama.cpp gave no answer: {str(message)[:300]}")
        for choice in chunk.get("choices") or []:
            delta = choice.get("delta") or {}
            if isinstance(delta.get("content"), str):
                content.append(delta["content"])
            for part in delta.get("tool_calls") or []:
                call = calls.setdefault(part.get("index", len(calls)),
                                        {"id": None, "type": "function", "function": {"name": "", "arguments": ""}})
                call["id"] = part.get("id") or call["id"]
                function = part.get("function") or {}
                call["function"]["name"] += function.get("name") or ""
                call["function"]["arguments"] += function.get("arguments") or ""
            finish = choice.get("finish_reason") or finish
        timings = chunk.get("timings") or timings  # on the last chunk: the model's own tokens and times
    if not chunks:
        raise BackendError("llama.cpp gave no answer")
    message: dict[str, Any] = {"role": "assistant", "content": "".join(content) or None}
    if calls:
        message["tool_calls"] = [calls[index] for index in sorted(calls)]
    completion: dict[str, Any] = {"choices": [{"index": 0, "message": message, "finish_reason": finish}]}
    if timings is not None:
        completion["timings"] = timings
    return completion
