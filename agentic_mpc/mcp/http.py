"""Serving over HTTP safely: the checks every HTTP endpoint of the project applies, and the MCP server over
streamable HTTP (``agentic-mpc serve --transport http``).

- DNS-rebinding protection, always on and explicit (:func:`security_settings`): a request whose ``Host`` is
  not the bind's own ``host:port`` (for a loopback bind also ``127.0.0.1``, ``localhost`` and ``[::1]`` at
  that port) or one the user allowed gets 421; an ``Origin`` other than ``http://`` + an allowed host, or
  one the user allowed, gets 403.
- A bearer token (:class:`BearerTokenMiddleware`, compared in constant time): without it, or with another,
  401 with ``WWW-Authenticate: Bearer``. A bind that is not loopback refuses to start without one
  (:func:`check_bind`).
- A body limit (413, :data:`MAX_BODY_BYTES`), a cap on concurrent connections (503) and on MCP sessions.
- A per-client rate limit on tool calls (:class:`RateLimiter`, a token bucket per MCP session, else per
  remote address). A call over the limit is answered with an MCP tool error result (``isError: true``)
  naming the limit and when to retry, and changes nothing. Why not HTTP 429 or a JSON-RPC error: every MCP
  client shows a tool error result to its model, which can wait and try again in the same session, while
  a 429 on the streamable HTTP POST or a JSON-RPC error surfaces as a failed request or transport failure
  (the Python SDK raises, bridges such as ``mcp-remote`` may drop the session).
- :class:`ShieldMiddleware`: an unexpected exception becomes one log line and a 500, never a traceback.

:func:`serve_http` binds the socket itself, so a port in use is one clear line (:class:`BindError`), then
runs uvicorn on it. The live view can wrap its own ASGI app with :func:`protect`.
"""

from __future__ import annotations

import errno
import hmac
import ipaddress
import json
import logging
import math
import socket
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from mcp.server.transport_security import TransportSecuritySettings
from starlette.types import ASGIApp, Receive, Scope, Send

logger = logging.getLogger(__name__)

TOKEN_ENV = "AGENTIC_MPC_TOKEN"
"""The environment variable ``serve`` reads the bearer token from."""
MAX_BODY_BYTES = 64 * 1024
"""Largest request body accepted (a tool call is a few hundred bytes; the SDK's default is 4 MiB)."""
MAX_CONNECTIONS = 256
"""Concurrent connections uvicorn accepts before answering 503."""
MAX_SESSIONS = 128
"""Concurrent MCP sessions (each holds memory on the server)."""
MIN_TOKEN_CHARS = 16
COOKIE = "agentic_mpc_token"
"""The cookie the live view's page keeps the bearer token in (see :class:`BearerTokenMiddleware`)."""

_LOOPBACK_NAMES = {"localhost", "localhost.localdomain", "ip6-localhost"}


class BindError(RuntimeError):
    """The server cannot listen where asked (a refusal before listening, or the port is taken)."""


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a bind address or name) is 127.0.0.0/8, ::1 or localhost."""
    name = host.strip().strip("[]").lower()
    if name in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def _host_header(host: str, port: int) -> str:
    host = host.strip()
    return f"[{host.strip('[]')}]:{port}" if ":" in host.strip("[]") else f"{host}:{port}"


def security_settings(host: str, port: int, allow_hosts: Iterable[str] = (),
                      allow_origins: Iterable[str] = ()) -> TransportSecuritySettings:
    """DNS-rebinding protection for a server bound to ``host:port`` (see the module docstring)."""
    hosts = [_host_header(host, port)]
    if is_loopback(host):
        hosts += [f"127.0.0.1:{port}", f"localhost:{port}", f"[::1]:{port}"]
    hosts += [h.strip() for h in allow_hosts if h.strip()]
    hosts = list(dict.fromkeys(hosts))
    origins = [f"http://{h}" for h in hosts] + [o.strip().rstrip("/") for o in allow_origins if o.strip()]
    return TransportSecuritySettings(enable_dns_rebinding_protection=True, allowed_hosts=hosts,
                                     allowed_origins=list(dict.fromkeys(origins)))


def check_bind(host: str, token: str | None) -> None:
    """Refuse (:class:`BindError`) a bind that is not loopback without a token, and a token too short."""
    if token is not None and len(token) < MIN_TOKEN_CHARS:
        raise BindError(f"the bearer token must have at least {MIN_TOKEN_CHARS} characters")
    if token is None and not is_loopback(host):
        raise BindError(
            f"refusing to listen on {host} without a bearer token: anyone who can reach it could change the "
            f"car's specification. Set {TOKEN_ENV}, pass --token-file PATH or --generate-token "
            "(or bind to 127.0.0.1)"
        )


def _cookie_value(header: bytes, name: bytes) -> bytes | None:
    for part in header.split(b";"):
        key, _, value = part.strip().partition(b"=")
        if key == name:
            return value.strip()
    return None


async def _send_json(send: Send, status: int, body: dict[str, Any], headers: Iterable[tuple[str, str]] = ()) -> None:
    payload = json.dumps(body).encode()
    raw = [(b"content-type", b"application/json"), (b"content-length", str(len(payload)).encode())]
    raw += [(k.lower().encode(), v.encode()) for k, v in headers]
    await send({"type": "http.response.start", "status": status, "headers": raw})
    await send({"type": "http.response.body", "body": payload})


class BearerTokenMiddleware:
    """ASGI: every HTTP request must carry ``Authorization: Bearer <token>`` (401 otherwise).

    A browser cannot add that header to a page it opens, so the live view's page also takes the token once
    as ``/?token=...``: that request is answered with a redirect to ``/`` setting the token as an HttpOnly,
    SameSite=Strict cookie (:data:`COOKIE`), which later requests may carry instead of the header."""

    def __init__(self, app: ASGIApp, token: str) -> None:
        self.app = app
        self._token = token.encode()

    def _valid(self, given: bytes | None) -> bool:
        return given is not None and hmac.compare_digest(given, self._token)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        given = cookie = None
        for key, value in scope.get("headers", ()):
            if key == b"authorization":
                scheme, _, credentials = value.partition(b" ")
                if scheme.lower() == b"bearer":
                    given = credentials.strip()
            elif key == b"cookie":
                cookie = _cookie_value(value, COOKIE.encode()) or cookie
        if self._valid(given) or (given is None and self._valid(cookie)):
            await self.app(scope, receive, send)
            return
        if given is None and scope.get("path") == "/" and scope.get("method") == "GET":
            from urllib.parse import parse_qs

            offered = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])[0]
            if self._valid(offered.encode()):
                cookie_header = f"{COOKIE}={offered}; HttpOnly; SameSite=Strict; Path=/"
                await send({"type": "http.response.start", "status": 303,
                            "headers": [(b"location", b"/"), (b"set-cookie", cookie_header.encode()),
                                        (b"cache-control", b"no-store"), (b"content-length", b"0")]})
                await send({"type": "http.response.body", "body": b""})
                return
        challenge = 'Bearer realm="agentic-mpc"' + ("" if given is None else ', error="invalid_token"')
        await _send_json(send, 401, {"error": "invalid_token" if given is not None else "unauthorized",
                                     "error_description": "a valid bearer token is required"},
                         [("WWW-Authenticate", challenge)])


class ShieldMiddleware:
    """ASGI: an exception escaping the app is one log line and a 500 (if nothing was sent yet)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        started = False

        async def tracking_send(message: dict[str, Any]) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, receive, tracking_send)
        except Exception as error:  # the shield's one job
            if scope["type"] != "http":
                raise
            logger.error("internal error answering %s %s: %r", scope.get("method"), scope.get("path"), error)
            if not started:
                await _send_json(send, 500, {"error": "internal server error"})


def protect(app: ASGIApp, token: str | None) -> ASGIApp:
    """``app`` behind the shield and, with a token, the bearer check (Host/Origin: :func:`security_settings`)."""
    guarded = BearerTokenMiddleware(app, token) if token else app
    return ShieldMiddleware(guarded)


@dataclass
class RateLimiter:
    """A token bucket per client: ``rate`` calls per second, bursts up to ``burst``. Thread-safe."""

    rate: float
    burst: float
    _buckets: dict[str, tuple[float, float]] = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    refused: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate) and self.rate > 0 and self.burst >= 1):
            raise ValueError("the rate limit must be positive")

    def retry_after(self, key: str, now: float | None = None) -> float | None:
        """Take one token for ``key``: None if there was one, else the seconds until there is."""
        now = time.monotonic() if now is None else now
        with self._lock:
            tokens, last = self._buckets.get(key, (self.burst, now))
            tokens = min(self.burst, tokens + (now - last) * self.rate)
            if tokens >= 1.0:
                self._buckets[key] = (tokens - 1.0, now)
                if len(self._buckets) > 4096:  # forget clients whose bucket is full again
                    full = now - self.burst / self.rate
                    self._buckets = {k: v for k, v in self._buckets.items() if v[1] > full}
                return None
            self._buckets[key] = (tokens, now)
            self.refused += 1
            return (1.0 - tokens) / self.rate

    def gate(self, caller: dict[str, Any]) -> str | None:
        """A :data:`~agentic_mpc.mcp.control_server.ToolCallGate`: keyed by MCP session, else address."""
        key = caller.get("session") or caller.get("address") or "local"
        wait = self.retry_after(str(key))
        if wait is None:
            return None
        if self.refused % 100 == 1:
            logger.warning("rate limit: refused tool calls from %s (%d refused so far)", key, self.refused)
        return (f"rate limit exceeded: at most {self.rate:g} tool calls per second per client (bursts of "
                f"{self.burst:g}); retry after {wait:.2f} s. The call was not run; the specification is unchanged.")


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port``; :class:`BindError` with one readable line if impossible."""
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM,
                                                             flags=socket.AI_PASSIVE)[0]
    except socket.gaierror as error:
        raise BindError(f"cannot listen on {host}:{port}: {error.strerror}") from None
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(2048)
    except OSError as error:
        sock.close()
        reason = "the port is already in use" if error.errno == errno.EADDRINUSE else (error.strerror or str(error))
        raise BindError(f"cannot listen on {_host_header(host, port)}: {reason}") from None
    sock.set_inheritable(True)
    return sock


def build_app(mcp_server: Any, host: str, port: int, *, token: str | None = None, allow_hosts: Iterable[str] = (),
              allow_origins: Iterable[str] = (), extra_routes: Iterable[Any] = ()) -> ASGIApp:
    """The MCP server's streamable HTTP app at ``/mcp``, with every check of the module docstring.
    ``extra_routes`` (the live view's) are served by the same app behind the same token and shield; they
    check Host and Origin themselves with :func:`security_settings` (as the SDK does for ``/mcp``)."""
    app = mcp_server.streamable_http_app(
        streamable_http_path="/mcp", max_request_body_size=MAX_BODY_BYTES, max_sessions=MAX_SESSIONS,
        transport_security=security_settings(host, port, allow_hosts, allow_origins), host=host,
    )
    app.router.routes.extend(extra_routes)
    return protect(app, token)


def serve_http(mcp_server: Any, sock: socket.socket, host: str, port: int, *, token: str | None = None,
               allow_hosts: Iterable[str] = (), allow_origins: Iterable[str] = (),
               extra_routes: Iterable[Any] = ()) -> None:
    """Run the MCP server on the listening ``sock`` until SIGINT/SIGTERM (uvicorn, one event loop)."""
    import asyncio

    import uvicorn

    app = build_app(mcp_server, host, port, token=token, allow_hosts=allow_hosts, allow_origins=allow_origins,
                    extra_routes=extra_routes)
    config = uvicorn.Config(app, log_level="warning", access_log=False, limit_concurrency=MAX_CONNECTIONS,
                            server_header=False, timeout_graceful_shutdown=3, lifespan="on")
    asyncio.run(uvicorn.Server(config).serve(sockets=[sock]))
