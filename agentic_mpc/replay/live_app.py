"""The live view's web routes (``agentic-mpc serve --view``), served by the same Starlette app and uvicorn
as the MCP endpoint, behind the same protections (:mod:`agentic_mpc.mcp.http`).

- ``GET /``: the replay page of the run so far (:class:`~agentic_mpc.replay.live.LiveScene`) with a chat box;
- ``GET /events``: server-sent events: ``chunk`` (what is new, about 5 times a second) and ``end``;
- ``POST /chat``: ``{"text": "..."}`` goes to the run's agent as the passenger's message (JSON only, at most
  :data:`MAX_CHAT_BYTES`, rate limited per address).

Every route checks ``Host`` and ``Origin`` like the MCP endpoint (DNS-rebinding protection); a token-protected
server also wants the token here (a header, or the cookie that ``/?token=...`` sets once).
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
from collections.abc import AsyncIterator, Callable
from typing import Any

from mcp.server.transport_security import TransportSecurityMiddleware, TransportSecuritySettings
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import Route

from agentic_mpc.replay.html import render_page
from agentic_mpc.replay.live import LiveScene

logger = logging.getLogger(__name__)

MAX_CHAT_BYTES = 4096
CHUNK_INTERVAL_S = 0.2
"""Wall time between two chunks a page receives (the run records traffic every 0.2 s by default)."""
MAX_STREAMS = 16
"""Pages open at once; more get 503 (each costs the server a little work every chunk)."""
PAGE_HEADERS = {
    "cache-control": "no-store",
    "x-frame-options": "DENY",  # nobody frames the chat box
    "content-security-policy": "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                               "connect-src 'self'; img-src 'self' data:; form-action 'self'",
    "referrer-policy": "no-referrer",
}


class LiveView:
    """The routes of one running simulation: ``scene`` to show, ``deliver(text)`` to reach its agent (returns
    the sim time it was delivered at), ``finished()`` once the run has ended (with the reason)."""

    def __init__(self, scene: LiveScene, deliver: Callable[[str], float], finished: Callable[[], str | None],
                 security: TransportSecuritySettings, chat_limiter: Any) -> None:
        self.scene = scene
        self._deliver = deliver
        self._finished = finished
        self._security = TransportSecurityMiddleware(security)
        self._chat_limiter = chat_limiter  # a mcp.http.RateLimiter
        self.streams = 0

    def routes(self) -> list[Route]:
        return [Route("/", self.page, methods=["GET"]), Route("/events", self.events, methods=["GET"]),
                Route("/chat", self.chat, methods=["POST"])]

    async def page(self, request: Request) -> Response:
        refused = await self._security.validate_request(request, is_post=False)
        if refused is not None:
            return refused
        scene = await asyncio.to_thread(self.scene.initial)
        return HTMLResponse(render_page(scene), headers=PAGE_HEADERS)

    async def events(self, request: Request) -> Response:
        refused = await self._security.validate_request(request, is_post=False)
        if refused is not None:
            return refused
        try:
            since = {key: max(0, int(request.query_params.get(key, "0")))
                     for key in ("track", "frames", "vehicles", "specs", "captions", "signals")}
        except ValueError:
            return JSONResponse({"error": "the counts in the query must be whole numbers"}, status_code=400)
        if self.streams >= MAX_STREAMS:
            return JSONResponse({"error": f"at most {MAX_STREAMS} live pages at once"}, status_code=503)
        return StreamingResponse(self._stream(request, since), media_type="text/event-stream",
                                 headers={"cache-control": "no-store", "x-accel-buffering": "no"})

    async def _stream(self, request: Request, since: dict[str, int]) -> AsyncIterator[str]:
        self.streams += 1
        try:
            while not await request.is_disconnected():
                new, since = await asyncio.to_thread(self.scene.chunk, since)
                if any(new.values()):
                    yield f"event: chunk\ndata: {json.dumps(new, separators=(',', ':'), allow_nan=False)}\n\n"
                ended = self._finished()
                if ended is not None:
                    yield f"event: end\ndata: {ended}\n\n"
                    return
                await asyncio.sleep(CHUNK_INTERVAL_S)
        finally:
            self.streams -= 1

    async def chat(self, request: Request) -> Response:
        refused = await self._security.validate_request(request, is_post=True)  # also: JSON only
        if refused is not None:
            return refused
        body = b""
        async for part in request.stream():
            body += part
            if len(body) > MAX_CHAT_BYTES:
                return JSONResponse({"error": f"a chat message is at most {MAX_CHAT_BYTES} bytes"}, status_code=413)
        try:
            text = json.loads(body).get("text")
        except (json.JSONDecodeError, UnicodeDecodeError, AttributeError):
            return JSONResponse({"error": 'the body must be JSON: {"text": "..."}'}, status_code=400)
        if not isinstance(text, str) or not text.strip():
            return JSONResponse({"error": '"text" must be a non-empty string'}, status_code=400)
        address = request.client.host if request.client else "local"
        wait = self._chat_limiter.retry_after(f"chat:{address}")
        if wait is not None:
            return JSONResponse({"error": f"at most {self._chat_limiter.rate:g} messages per second; retry after "
                                          f"{wait:.1f} s"}, status_code=429, headers={"retry-after": str(math.ceil(wait))})
        ended = self._finished()
        if ended is not None:
            return JSONResponse({"error": f"the run has ended ({ended})"}, status_code=409)
        try:
            sim_time_s = self._deliver(text.strip())
        except Exception as error:  # the agent refused it: say why, the run goes on
            logger.warning("chat message not delivered: %r", error)
            return JSONResponse({"error": f"not delivered: {error}"}, status_code=503)
        return JSONResponse({"ok": True, "sim_time_s": sim_time_s if math.isfinite(sim_time_s) else None})
