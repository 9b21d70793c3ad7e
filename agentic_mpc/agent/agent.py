"""The agent of the paper's section "Agent": a message history driven by a backend, acting through MCP.

A new user message (typed, or generated from an observation) starts an agent step: it is appended to the
history, the backend answers with text and tool calls, each call goes to the MCP server and its result is
appended, and the backend is asked again, until it answers without tool calls; then the agent idles until
the next message. One exception, the restore reminder (``AgentConfig.restore_reminder``, off by default:
:func:`agentic_mpc.agent.reminder.remind_to_restore`). The system message (tau = 0) holds the road (``sumo://road``), the initially
attached primitives and the tools, so the agent can restore the original specification; a language model
reads it as soon as the agent starts (``warm_up``), so that a message costs only its own tokens. Tool calls
are run by :mod:`agentic_mpc.agent.tool_calls`; answers are asked for by :mod:`agentic_mpc.agent.backend_calls`.

A step ends: without calls (``idle``); on calls it already made (``repeated``) or one that puts the
specification back as it was before the call just made (``undone``); when its time or token budget is spent
(``budget``); after ``max_rounds_per_step`` answers. What it changed until then stands.

The agent talks to the controller ONLY through the MCP server, with ``mcp.Client``: in-process by default
(pass the ``MCPServer``, or any object with an ``mcp_server`` attribute holding one), or a server in another
process (``StdioServerParameters``) or over HTTP (a URL; ``AgentConfig.bearer_token_env`` names the environment
variable holding the server's bearer token, ``AgentConfig.headers`` adds any other header). Of the MCP side it
imports only the client contract, :mod:`agentic_mpc.mcp.protocol`, never the server's implementation. It runs
in its own thread with its own event loop: the control loop never waits for it.

Timing modes (``AgentConfig.mode``):

- ``realtime``: a message is processed as it arrives; tool calls apply when they reach the server. How long
  the backend thinks is how long the car drives on the old specification.
- ``lockstep``: reproducible. ``deliver(text, sim_time_s=t)`` blocks the caller (the simulation, so sim time
  is frozen) until the agent is idle again, and every tool call of that step carries
  ``_meta["agentic-mpc/apply_at_s"] = t + latency_s``: the server validates it at once and applies it when
  the simulation reaches t + latency_s, as if the agent had thought for ``latency_s``. With a deterministic
  backend the whole run is deterministic.

The run loop wires it to a simulation; it reads the moment over MCP too (situation, emergency events: situation.py).

Bad input never stops the car: empty, oversized or non-text messages are rejected before they become a step;
unknown tools, unparseable or schema-violating arguments (including NaN) are answered with a tool error
message (the backend may correct itself, at most ``max_consecutive_errors`` rounds in a row); an unreachable
or timed-out backend is retried ``backend_attempts`` times, then the step ends. Each is in the transcript
(:mod:`agentic_mpc.agent.transcript`) and the log; the controller keeps its last valid specification.
"""

from __future__ import annotations

import asyncio
import logging
import math
import threading
from collections.abc import Callable
from concurrent.futures import Future
from contextlib import AsyncExitStack
from dataclasses import replace
from functools import partial
from typing import Any

from mcp import Client

from agentic_mpc.agent.backend_calls import BudgetSpent, StepBudget, complete, warm_up
from agentic_mpc.agent.backends.base import Backend, BackendError, ToolSpec
from agentic_mpc.agent.config import AgentConfig, AgentError, WatchRequest, check_message, root_cause
from agentic_mpc.agent.connect import CLIENT_INFO, mcp_target, read_json_resource
from agentic_mpc.agent.hosting import ServerHost, target_of
from agentic_mpc.agent.memory_recall import memory_json, open_session
from agentic_mpc.agent.messages import Message, MessageHistory, Source
from agentic_mpc.agent.prompt import system_prompt
from agentic_mpc.agent.reminder import remind_to_restore
from agentic_mpc.agent.report import StepReport, answer_closed
from agentic_mpc.agent.report import attached_of as _attached
from agentic_mpc.agent.retrieval import retrieved_message
from agentic_mpc.agent.situation import EmergencyWatch, read_situation
from agentic_mpc.agent.tool_calls import ToolRunner, call_key
from agentic_mpc.agent.transcript import Transcript
from agentic_mpc.mcp.protocol import INITIAL_SPECIFICATION_URI, ROAD_URI, SPECIFICATION_URI

logger = logging.getLogger(__name__)


class Agent:
    """The agent (see the module docstring). Use as a context manager, or ``start()`` / ``close()``.

    ``server`` is anything ``mcp.Client`` connects to: an ``MCPServer`` for in-process,
    ``StdioServerParameters`` for a subprocess, a URL for streamable HTTP; or any object with an
    ``mcp_server`` attribute (such as :class:`agentic_mpc.mcp.server.AgenticMPCServer`), whose value is used.
    ``sim_clock``, if given, stamps sim time on messages that arrive without one (realtime mode).
    """

    def __init__(
        self,
        backend: Backend,
        server: Any,
        config: AgentConfig | None = None,
        sim_clock: Callable[[], float] | None = None,
        other_servers: dict[str, Any] | None = None,
    ) -> None:
        self.backend = backend
        self.server = getattr(server, "mcp_server", server)
        self.config = config or AgentConfig()
        self.other_servers = {**(other_servers or {}), **{e.name: target_of(e) for e in self.config.mcp_servers}}
        """Servers besides the controller's (name -> what ``mcp.Client`` connects to): agent/hosting.py."""
        self.sim_clock = sim_clock
        self.history = MessageHistory()
        self.memory, self.memory_error = open_session(self.config.memory, self.config.transcript_path)
        self.backend = backend
        self.transcript = Transcript(self.config.transcript_path)
        if self.memory_error is not None:  # on_error: ignore
            self.transcript.record("memory_error", tau=None, sim_time_s=None, error=self.memory_error)
        self._runner = ToolRunner(self.transcript, self.config.tool_timeout_s)
        self.tools: tuple[ToolSpec, ...] = ()
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._queue: asyncio.Queue[tuple[Message | WatchRequest, Future[Any]] | None] | None = None
        self._watch = EmergencyWatch()  # the run's emergency events, read over MCP (the run decides them)
        self._watch_queued = False  # realtime: one pending check is enough, however many updates arrived
        self._ready = threading.Event()
        self.warmed = threading.Event()
        """Set once the model has read the system message (at once for backends without a prompt cache)."""
        self._system_tokens: int | None = None  # as the model's server counted them at the warm-up
        self._startup_error: BaseException | None = None
        self._client: Client | None = None
        self._host: ServerHost | None = None
        self._initial: dict[str, Any] | None = None  # mpc://specification/initial, read at the start
        self._closed = False

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> Agent:
        if self._thread is not None:
            return self
        self._thread = threading.Thread(target=self._thread_main, name="agent", daemon=True)
        self._thread.start()
        if not self._ready.wait(self.config.startup_timeout_s):
            raise AgentError(f"the agent did not connect to the MCP server within {self.config.startup_timeout_s} s")
        if self._startup_error is not None:
            cause = root_cause(self._startup_error)
            raise AgentError(f"the agent could not start: {cause!r}") from cause
        return self

    def close(self, timeout_s: float = 10.0) -> None:
        if self._closed:
            return
        self._closed = True
        if self._loop is not None and self._queue is not None and not self._loop.is_closed():
            try:
                self._loop.call_soon_threadsafe(self._queue.put_nowait, None)
            except RuntimeError:
                pass
        if self._thread is not None:
            self._thread.join(timeout_s)
        self.transcript.close()

    def __enter__(self) -> Agent:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _thread_main(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as error:  # noqa: BLE001 - reported through start() or the log
            if not self._ready.is_set():
                self._startup_error = error
                self._ready.set()
            else:
                logger.exception("the agent's event loop stopped")

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._queue = asyncio.Queue()
        try:
            target = mcp_target(self.server, self.config.headers, self.config.bearer_token_env)
            async with Client(target, cache=None, client_info=CLIENT_INFO) as client, AsyncExitStack() as stack:
                self._client, self._host = client, ServerHost(client)
                await self._host.connect(stack, self.other_servers)
                await self._introduce(client)
                self._ready.set()
                await self._warm()
                listening = (asyncio.create_task(self._listen(client)) if self.config.observation_messages
                             and self.config.mode == "realtime" else None)
                while True:
                    item = await self._queue.get()
                    if item is None:
                        break
                    message, future = item
                    if isinstance(message, WatchRequest):
                        future.set_result(await self._watch_step(client, message.sim_time_s))
                        continue
                    try:
                        report = await self._run_step(message)
                    except Exception as error:  # never leave a caller waiting on a crashed step
                        logger.exception("agent step failed")
                        report = StepReport(message.content, message.source or "user", message.sim_time_s)
                        report.errors.append(f"internal error: {error!r}")
                        report.ended = "gave_up"
                    future.set_result(report)
                if listening is not None:
                    listening.cancel()
        finally:
            answer_closed(self._queue)
            try:
                await self.backend.aclose()
            except Exception:
                logger.exception("closing the backend failed")

    async def _introduce(self, client: Client) -> None:
        listed = await client.list_tools()
        self.tools = tuple(ToolSpec(t.name, t.description or "", dict(t.input_schema)) for t in listed.tools)
        if not self.tools:
            raise AgentError("the MCP server lists no tools")
        self.tools += self._host.tools  # the other servers' (namespaced); those that failed are said here
        for reason in self._host.errors:
            self.transcript.record("server_error", tau=None, sim_time_s=self._now(None), error=reason)
        initial = await read_json_resource(client, INITIAL_SPECIFICATION_URI)  # None: the agent cannot restore
        self._initial = initial  # a language model reads tool results as one line against it (tool_calls.py):
        self._runner.initial = initial if getattr(self.backend, "reads_situation", True) else None
        road = await read_json_resource(client, ROAD_URI, missing=logging.INFO)  # None: an older server
        model = getattr(self.backend, "model", self.backend) if hasattr(self.backend, "rules") else self.backend
        prompt = getattr(model, "system_prompt", None) or system_prompt  # a model's own (compact_prompt.py)
        system = self.history.append(
            Message(
                "system",
                prompt(initial, self.tools, self.config.extra_prompt, road=road),
                data={"initial_specification": initial, "road": road, "tools": [t.to_openai() for t in self.tools]},
                sim_time_s=self._now(None),
            )
        )
        self.transcript.message(system)
        if self.config.observation_messages:  # what is over before the agent came does not wake it
            await self._watch.start(client)

    async def _warm(self) -> None:
        """Have the model read the system message now (``AgentConfig.warm_up``; agent/backend_calls.py)."""
        try:
            if self.config.warm_up:
                self._system_tokens = await warm_up(self.backend, self.history.messages[:1], self.tools,
                                                    self.config, self.transcript, partial(self._now, None))
        finally:
            self.warmed.set()

    # ------------------------------------------------------------------ inputs
    def _now(self, frozen: float | None) -> float | None:
        if frozen is not None:
            return frozen
        if self.sim_clock is None:
            return None
        try:
            return float(self.sim_clock())
        except Exception:
            return None

    def deliver(self, text: Any, sim_time_s: float | None = None, source: Source = "user") -> Future[StepReport]:
        """Hand the agent a message. Realtime: returns at once. Lockstep: returns when the agent is idle again."""
        future: Future[StepReport] = Future()
        t = sim_time_s if sim_time_s is not None else self._now(None)
        if self.config.mode == "lockstep" and (t is None or not math.isfinite(t)):
            raise ValueError("lockstep mode needs the sim time of every message (sim_time_s or sim_clock)")
        problem = check_message(text, self.config.max_message_chars)
        if problem is None and (self._closed or self._loop is None or self._queue is None):
            problem = "the agent is not running"
        if problem is not None:
            preview = text[:200] if isinstance(text, str) else repr(text)[:200]
            logger.warning("rejected %s message: %s", source, problem)
            self.transcript.record("rejected_input", tau=self.history.tau, sim_time_s=t, source=source, error=problem,
                                   preview=preview, length=len(text) if isinstance(text, str) else None)
            future.set_result(StepReport(preview, source, t, errors=[problem], ended="rejected"))
            return future
        message = Message("user", text.replace("\x00", ""), source=source, sim_time_s=t)
        self._loop.call_soon_threadsafe(self._queue.put_nowait, (message, future))  # type: ignore[union-attr]
        if self.config.mode == "lockstep":
            future.result(timeout=self.config.lockstep_timeout_s)
        return future

    def memory_json(self) -> dict[str, Any] | None:
        """What ``agent://memory`` shows (agent/memory_recall.py)."""
        return memory_json(self.memory, self.memory_error)

    def watch(self, sim_time_s: float) -> Future[list[StepReport]]:
        """Lockstep: check ``sumo://emergency-vehicles`` now (the simulation waits) and run a step for each
        event it brings, stamped ``sim_time_s``. (Realtime agents watch by themselves: subscribed.)"""
        future: Future[list[StepReport]] = Future()
        if self._closed or self._loop is None or self._queue is None:
            future.set_result([])
            return future
        self._loop.call_soon_threadsafe(self._queue.put_nowait, (WatchRequest(sim_time_s), future))
        if self.config.mode == "lockstep":
            future.result(timeout=self.config.lockstep_timeout_s)
        return future

    async def _listen(self, client: Client) -> None:
        """Realtime: queue a check on every update of ``sumo://emergency-vehicles`` (one pending is enough)."""
        def wake() -> None:
            if not self._watch_queued and self._queue is not None:
                self._watch_queued = True
                self._queue.put_nowait((WatchRequest(None), Future()))
        error = await self._watch.listen(client, wake)  # returns only if the server cannot notify
        self.transcript.record("watch_error", tau=self.history.tau, sim_time_s=self._now(None), error=error)

    async def _watch_step(self, client: Client, sim_time_s: float | None) -> list[StepReport]:
        self._watch_queued = False
        reports = []
        for event in await self._watch.check(client):
            stamp = sim_time_s if sim_time_s is not None else event.time_s
            logger.info("the watch saw %s at t=%.2f s", event.kind, event.time_s)
            reports.append(await self._run_step(
                Message("user", event.message(), source="observation", sim_time_s=round(stamp, 3))))
        return reports

    # ------------------------------------------------------------------ one agent step
    def _append(self, message: Message) -> Message:
        stamped = self.history.append(message)
        self.transcript.message(stamped)
        return stamped

    async def _run_step(self, incoming: Message) -> StepReport:
        frozen = incoming.sim_time_s if self.config.mode == "lockstep" else None
        apply_at = None if frozen is None else frozen + self.config.latency_s
        budget = StepBudget(self.config.step_budget_s, self.config.step_budget_tokens)
        model = getattr(self.backend, "reads_situation", True) and self._client is not None
        user = self._append(await self._with_context(incoming, model))
        report = StepReport(user.content, user.source or "user", user.sim_time_s, first_tau=user.tau)
        now = partial(self._now, frozen)
        consecutive_errors = 0
        made: set[str] = set()  # the calls this step ran successfully, to stop a model that repeats them
        # the specification before each successful call of the step, to stop a model that undoes its last one
        states = [_attached(await read_json_resource(self._client, SPECIFICATION_URI))] if model else []
        reminded = False
        for round_index in range(self.config.max_rounds_per_step):
            if (spent := budget.spent(report.usage)) is not None:
                report.errors.append(spent)
                report.ended = "budget"
                break
            try:
                reply = await complete(self.backend, self.history.messages, self.tools, self.config,
                                       self.transcript, now, budget, self._system_tokens)
            except BackendError as error:
                report.errors.append(str(error))
                report.ended = "budget" if isinstance(error, BudgetSpent) else "backend_error"
                break
            report.usage.add(reply.usage)
            calls = reply.tool_calls
            last_round = round_index + 1 >= self.config.max_rounds_per_step
            if not (calls or made or reminded or last_round) and await remind_to_restore(self, reply.text, frozen):
                reminded = True
                continue
            agent_message = self._append(Message("assistant", reply.text, tool_calls=calls, sim_time_s=now()))
            report.text = reply.text
            if not calls:
                report.ended = "idle"
                break
            if made and all(call_key(call) in made for call in calls):
                report.ended = "repeated"
                self.transcript.record("repeated_calls", tau=agent_message.tau, sim_time_s=now(),
                                       calls=[call.describe() for call in calls])
                break
            failures = 0
            for index, call in enumerate(calls):
                if index >= self.config.max_tool_calls_per_round:
                    limit = self.config.max_tool_calls_per_round
                    result = self._runner.refuse(call, f"too many tool calls in one answer (at most {limit})", now)
                else:
                    result = await self._runner.execute(self._host, self.tools, call, apply_at,
                                                        agent_message.tau, now)
                stamped = self._append(result)
                if report.add_call(call, stamped, apply_at):
                    made.add(call_key(call))
                    states.append(_attached(stamped.data))
                else:
                    failures += 1
            consecutive_errors = consecutive_errors + 1 if failures == len(calls) else 0
            if consecutive_errors >= self.config.max_consecutive_errors:
                report.ended = "gave_up"
                break
            if len(states) >= 3 and states[-1] is not None and states[-1] == states[-3] != states[-2]:
                report.ended = "undone"  # back to what it was before the call just made: no end to this
                self.transcript.record("undone_call", tau=self.history.tau, sim_time_s=now(),
                                       calls=[call.describe() for call in calls])
                break
        else:
            report.ended = "round_limit"
        report.wall_s = round(budget.elapsed_s(), 3)
        report.last_tau = self.history.tau
        if self.memory is not None:  # a stated preference or a correction is kept for the next runs
            self.memory.after(user, report.applied_calls, self.transcript, report.last_tau)
        report.close(self.transcript, now())
        return report

    async def _with_context(self, incoming: Message, model: bool) -> Message:
        """The message with what a model reads beside it: the situation, the passages that bear on it
        (retrieval.py) and what the passenger said in earlier runs (memory: context lines and data)."""
        if self.config.situation and model:
            incoming = replace(incoming, context=await read_situation(self._client))
        if self.config.retrieval and model and self._host is not None:
            road = (self.history.messages[0].data or {}).get("road")
            incoming = await retrieved_message(incoming, self._host, self.tools, road)
        if self.memory is not None:
            incoming = self.memory.before(incoming, self.transcript, self.history.tau + 1)
        return incoming

