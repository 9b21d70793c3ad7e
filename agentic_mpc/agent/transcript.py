"""The agent's transcript: one JSON object per line for every message, tool call, result and error.

Every record has ``event``, ``tau`` (the agent step it belongs to), ``sim_time_s`` (None when unknown) and
``wall_time_s`` (seconds since the agent started). Events: ``message`` (any appended message),
``tool_call`` (before it is sent: tool, arguments, ``apply_at_s`` in lockstep), ``tool_result`` (result or
``error``), ``rejected_input`` (an empty, oversized or malformed message that never became a step),
``backend_error`` (the backend gave no usable answer; ``attempt``), ``restore_reminder`` (an answer without
a call while the specification differs from the initial one: ``changes``, and ``withheld_answer``, the
answer, which stays out of the history; the agent's note is the next ``message``),
``step_end`` (why the step ended).
"""

from __future__ import annotations

import json
import math
import threading
import time
from pathlib import Path
from typing import IO, Any


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


class Transcript:
    """Thread-safe JSONL writer; keeps the records in memory too (``records``)."""

    def __init__(self, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self.records: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        self._started = time.perf_counter()
        self._file: IO[str] | None = None
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("a", encoding="utf-8")

    def record(self, event: str, *, tau: int | None, sim_time_s: float | None, **fields: Any) -> dict[str, Any]:
        entry = {
            "event": event,
            "tau": tau,
            "sim_time_s": sim_time_s,
            "wall_time_s": round(time.perf_counter() - self._started, 6),
            **fields,
        }
        entry = _finite(entry)
        with self._lock:
            self.records.append(entry)
            if self._file is not None:
                self._file.write(json.dumps(entry, default=str, allow_nan=False) + "\n")
                self._file.flush()
        return entry

    def message(self, message: Any) -> dict[str, Any]:
        """Record an appended :class:`~agentic_mpc.agent.messages.Message`."""
        described = message.describe()
        return self.record(
            "message", tau=described.pop("tau"), sim_time_s=described.pop("sim_time_s", None), **described
        )

    def events(self, event: str) -> list[dict[str, Any]]:
        with self._lock:
            return [r for r in self.records if r["event"] == event]

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None
