"""A real OpenAI-compatible HTTP server on 127.0.0.1 that answers from a script (a stand-in for Ollama/vLLM).

Each POST to ``/v1/chat/completions`` takes the next scripted answer:

- a dict: the ``message`` of a chat completion (``{"content": ..., "tool_calls": [...]}``);
- ``Raw(status, body)``: any HTTP status and body (malformed responses);
- ``Delay(seconds, answer)``: wait, then answer (a model that thinks, or one that times out).

When the script runs out it answers text without tool calls. Requests are kept in ``requests``; a warm-up
(the agent's one-token request that has the model read the system message, ``max_tokens: 1``) is answered
without taking a scripted answer and kept in ``warmups``.
"""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass
class Raw:
    status: int
    body: str


@dataclass
class Delay:
    seconds: float
    answer: Any


def tool_call(name: str, arguments: Any, call_id: str | None = None) -> dict[str, Any]:
    raw = arguments if isinstance(arguments, str) else json.dumps(arguments)
    return {"id": call_id or f"call-{name}", "type": "function", "function": {"name": name, "arguments": raw}}


def calls(*tool_calls: dict[str, Any], content: str | None = None) -> dict[str, Any]:
    return {"role": "assistant", "content": content, "tool_calls": list(tool_calls)}


def text(content: str) -> dict[str, Any]:
    return {"role": "assistant", "content": content}


class ScriptedLLM:
    def __init__(self, script: list[Any] | None = None, timings: dict[str, Any] | None = None,
                 warmup_s: float = 0.0) -> None:
        self.script = list(script or [])
        self.warmup_s = warmup_s  # how long reading the system message takes it
        self.timings = timings  # added to every completion as llama.cpp's server reports its own cost
        self.requests: list[dict[str, Any]] = []
        self.warmups: list[dict[str, Any]] = []
        self.headers: list[dict[str, str]] = []
        self.request_times: list[float] = []
        self._lock = threading.Lock()
        owner = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:  # keep test output clean
                pass

            def do_POST(self) -> None:  # noqa: N802 - http.server's naming
                length = int(self.headers.get("Content-Length", 0))
                body = json.loads(self.rfile.read(length) or b"{}")
                if body.get("max_tokens") == 1:  # the agent's warm-up: not a step's answer
                    time.sleep(owner.warmup_s)
                    with owner._lock:
                        owner.warmups.append(body)
                    payload = json.dumps({"choices": [{"index": 0, "message": text("."), "finish_reason": "length"}]})
                    self._send(200, payload)
                    return
                with owner._lock:
                    owner.requests.append(body)
                    owner.headers.append(dict(self.headers))
                    owner.request_times.append(time.perf_counter())
                    answer = owner.script.pop(0) if owner.script else text("Nothing more to do.")
                if not self.path.endswith("/chat/completions"):
                    answer = Raw(404, '{"error": "not found"}')
                while isinstance(answer, Delay):
                    time.sleep(answer.seconds)
                    answer = answer.answer
                if isinstance(answer, Raw):
                    status, payload = answer.status, answer.body
                else:
                    status = 200
                    payload = json.dumps({
                        "id": "chatcmpl-scripted", "object": "chat.completion", "model": body.get("model"),
                        "choices": [{"index": 0, "message": answer, "finish_reason": "tool_calls"}],
                        **({"timings": owner.timings} if owner.timings else {}),
                    })
                self._send(status, payload)

            def _send(self, status: int, payload: str) -> None:
                data = payload.encode()
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):  # the client timed out and left
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"

    def __enter__(self) -> ScriptedLLM:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
