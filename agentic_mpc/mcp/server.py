"""The MCP server: the controller tools and the world's observations, for the agent or any MCP host.

Built on the mcp 2.x SDK's ``MCPServer``. The same server serves the embedded agent (in-process, through
``mcp.Client(server)``), a host over stdio, or a host over streamable HTTP (``agentic-mpc serve``).

Tools (arguments bounded by JSON schemas; anything else is an MCP tool error and changes nothing):
``run_center_lane(v_ref)``, ``run_left_lane(v_ref)``, ``run_right_lane(v_ref)``, ``set_reference_speed(v_ref)``
(``v_ref`` in m/s, 0 to the road speed limit), ``set_preferred_steering_direction(direction)`` (``left`` or
``right``), ``clear_preferred_steering_direction()``. Each returns the specification now attached (or, when
scheduled, the one that will be). Arguments are checked against the published schema before the tool runs:
unknown arguments, wrong types, out-of-range and non-finite numbers are refused.

Resources (JSON, :mod:`agentic_mpc.mcp.resources`): ``sumo://ego``, ``sumo://traffic``, ``sumo://emergency-vehicles``, ``sumo://obstacles``
(from the world's latest observation), ``sumo://vehicle/{vehicle_id}`` (one road user by id), ``sumo://road``
(lanes, handedness, edge lane, speed limit, what yielding and resuming mean: :mod:`agentic_mpc.mcp.road`),
``mpc://specification`` (attached now, version, pending scheduled changes), ``mpc://specification/initial``
and ``mpc://pool`` (every primitive family and its parameters). A client that listens
(``subscriptions/listen``) gets ``ResourceUpdated`` events as the simulation advances (observation URIs at
most every ``publish_interval_s`` of sim time) and whenever the specification changes.

Scheduling: a ``tools/call`` whose ``_meta`` carries ``"agentic-mpc/apply_at_s": t`` is validated now and
applied when the simulation reaches sim time t (the agent's lockstep mode). Without it a call applies at once.

Who called: every tool call the server receives is reported to :attr:`AgenticMPCServer.on_tool_call` with the
client that made it (its ``initialize`` name/version, the MCP session id and remote address over HTTP); the run
loop records them in ``events.csv`` (``tool_call_received``). Over HTTP see :mod:`agentic_mpc.mcp.http` for
the Host/Origin checks, the bearer token and the per-client rate limit.

The URIs, the ``_meta`` key and the argument check are the client-side contract, in
:mod:`agentic_mpc.mcp.protocol`; a client imports that, never this module.

Connecting an MCP host
----------------------
Claude Desktop (``claude_desktop_config.json``)::

    {"mcpServers": {"agentic-mpc": {"command": "agentic-mpc", "args": ["serve", "--transport", "stdio"]}}}

(use the absolute path of the ``agentic-mpc`` script of your virtual environment if it is not on PATH).
MCP Inspector, command-line mode::

    npx @modelcontextprotocol/inspector --cli agentic-mpc serve --transport stdio --method tools/list
    npx @modelcontextprotocol/inspector --cli agentic-mpc serve --transport stdio \\
        --method tools/call --tool-name run_left_lane --tool-arg v_ref=0
    npx @modelcontextprotocol/inspector --cli agentic-mpc serve --transport stdio \\
        --method resources/read --uri sumo://traffic

(these three were run against this server with ``@modelcontextprotocol/inspector`` 0.15.0 from npm). Over HTTP:
``agentic-mpc serve --transport http --port 8765``, then point the host at ``http://127.0.0.1:8765/mcp``
(streamable HTTP). From Python::

    from mcp import Client, StdioServerParameters
    params = StdioServerParameters(command="agentic-mpc", args=["serve", "--transport", "stdio"])
    async with Client(params) as client:
        await client.call_tool("run_left_lane", {"v_ref": 0})
        traffic = await client.read_resource("sumo://traffic")
        async with client.listen(resource_subscriptions=["sumo://traffic"]) as events:
            async for event in events: ...
"""

# No `from __future__ import annotations`: the SDK reads the tool closures' annotations at runtime.
import asyncio
import inspect
import json
import logging
import math
import threading
from collections.abc import Callable
from typing import Any

import anyio.lowlevel
from mcp.server.mcpserver import Context
from mcp.server.mcpserver.exceptions import ToolError
from mcp.server.mcpserver.tools import Tool
from mcp.server.subscriptions import ResourceUpdated, ServerEvent
from mcp_types import CallToolResult, TextContent

from agentic_mpc.mcp.control_server import ControlServer, ToolCallHook
from agentic_mpc.mcp.protocol import (
    APPLY_AT_META_KEY,
    EGO_URI,
    EMERGENCY_VEHICLES_URI,
    INITIAL_SPECIFICATION_URI,
    OBSTACLES_URI,
    ROAD_URI,
    SPECIFICATION_URI,
    TACTICS_URI,
    TRAFFIC_URI,
)
from agentic_mpc.mcp.resources import ObservationSource, register_resources, to_json
from agentic_mpc.mcp.road import LaneIndex
from agentic_mpc.mcp.tool_table import instances
from agentic_mpc.mcp.tools import ControllerTools, ToolCallError

logger = logging.getLogger(__name__)

class ThreadSafeSubscriptionBus:
    """A ``SubscriptionBus`` that may be published to from any thread.

    The SDK's in-memory bus calls listeners directly, which is only safe on the listener's own event loop.
    The simulation publishes from its own thread, and the embedded agent's in-process server runs on the
    agent's loop: so each listener is remembered with the loop it subscribed on and called there.
    """

    def __init__(self) -> None:
        self._listeners: dict[object, tuple[asyncio.AbstractEventLoop | None, Callable[[ServerEvent], None]]] = {}
        self._lock = threading.Lock()

    async def publish(self, event: ServerEvent) -> None:
        self.publish_threadsafe(event)
        await anyio.lowlevel.checkpoint()

    def subscribe(self, listener: Callable[[ServerEvent], None]) -> Callable[[], None]:
        try:
            loop: asyncio.AbstractEventLoop | None = asyncio.get_running_loop()
        except RuntimeError:
            loop = None
        token = object()
        with self._lock:
            self._listeners[token] = (loop, listener)

        def unsubscribe() -> None:
            with self._lock:
                self._listeners.pop(token, None)

        return unsubscribe

    @property
    def listener_count(self) -> int:
        return len(self._listeners)

    def publish_threadsafe(self, event: ServerEvent) -> None:
        with self._lock:
            listeners = list(self._listeners.values())
        if not listeners:
            return
        try:
            running: asyncio.AbstractEventLoop | None = asyncio.get_running_loop()
        except RuntimeError:
            running = None
        for loop, listener in listeners:
            if loop is None or loop is running:
                _deliver(listener, event)
            elif not loop.is_closed():
                try:
                    loop.call_soon_threadsafe(_deliver, listener, event)
                except RuntimeError:  # the loop closed in between: that listener is gone
                    pass


def _deliver(listener: Callable[[ServerEvent], None], event: ServerEvent) -> None:
    try:
        listener(event)
    except Exception:  # one bad listener must not starve the others
        logger.exception("a subscription listener raised")


class AgenticMPCServer:
    """The MCP server over one :class:`ControllerTools` and one observation source.

    :attr:`mcp_server` (also ``server``) is the SDK's ``MCPServer``: hand it to ``mcp.Client`` or run it (the
    agent accepts this object itself and connects to that attribute). Call :meth:`publish_observation` after
    every simulation step (any thread) to notify listening clients. ``lane_index`` (the world's
    ``lane_index_of``) gives ``sumo://road`` the world's lane indices, ``jurisdiction`` (the scenario's: ``JP``,
    ``DE``, ...) whose traffic rules apply there, ``road_type`` (``motorway``, ``rural``, ``urban``) which of its
    speed limits, ``tactics`` (the run's tactics layer's ``to_json``) what ``mpc://tactics`` reads.
    """

    def __init__(
        self,
        tools: ControllerTools,
        latest_observation: ObservationSource,
        *,
        name: str = "agentic-mpc",
        max_speed_mps: float | None = None,
        publish_interval_s: float = 0.2,
        on_tool_call: ToolCallHook | None = None,
        lane_index: LaneIndex | None = None,
        jurisdiction: str | None = None,
        road_type: str | None = None,
        tactics: Callable[[], dict[str, Any]] | None = None,
        memory: Callable[[], dict[str, Any] | None] | None = None,
        route: Callable[[], dict[str, Any]] | None = None,
    ) -> None:
        self.tools = tools
        self.lane_index = lane_index
        self.latest_observation = latest_observation
        if max_speed_mps is not None:  # every tool accepts up to it, not only the schemas say so
            tools.speed_ceiling_mps = float(max_speed_mps)
        self.max_speed_mps = float(max_speed_mps if max_speed_mps is not None else tools.road().speed_limit_mps)
        if not (math.isfinite(self.max_speed_mps) and self.max_speed_mps > 0):
            raise ValueError(f"max_speed_mps must be a positive number, got {self.max_speed_mps!r}")
        self.publish_interval_s = publish_interval_s
        self.bus = ThreadSafeSubscriptionBus()
        self._last_published_s = -math.inf
        self._last_static: dict[str, str] = {}
        self.server = ControlServer(
            name,
            instructions=self._instructions(),
            subscriptions=self.bus,
            tools=self._tools(),
            log_level="WARNING",
        )
        self.server.on_tool_call = on_tool_call
        register_resources(self.server, tools, latest_observation, lane_index, jurisdiction, road_type, tactics,
                           memory, route)
        tools.slot.subscribe(lambda spec, version: self.bus.publish_threadsafe(ResourceUpdated(uri=SPECIFICATION_URI)))

    @property
    def on_tool_call(self) -> ToolCallHook | None:
        """Called with one dict per tool call received (``tool``, ``arguments``, ``ok``, ``error``,
        ``result`` (a summary), ``apply_at_s``, ``client``, ``session``, ``address``), from the server's thread."""
        return self.server.on_tool_call

    @on_tool_call.setter
    def on_tool_call(self, hook: ToolCallHook | None) -> None:
        self.server.on_tool_call = hook

    @property
    def mcp_server(self) -> ControlServer:
        """The SDK server (what ``mcp.Client`` connects to in-process, or what runs over stdio or HTTP)."""
        return self.server

    # ------------------------------------------------------------------ tools
    def _instructions(self) -> str:
        return (
            "Tools and observations of an autonomous car driven by a model predictive controller (Fourier "
            "MPPI). The controller minimises a sum of attached primitive objectives; the tools attach or "
            "detach them. Speeds are in m/s (1 m/s = 3.6 km/h), between 0 and the road speed limit "
            f"({self.max_speed_mps:g} m/s). Read {INITIAL_SPECIFICATION_URI} for the original specification and "
            f"{ROAD_URI} for the road (lanes, handedness, what yielding to an emergency vehicle means)."
        )

    def _tools(self) -> list[Tool]:
        """Every row of the one tool table (mcp/tool_table.py) for this road's lanes, as SDK tools."""
        built = []
        for name, definition, lane in instances(self.tools):
            tool = Tool.from_function(_mcp_function(definition.bind(self.tools, lane),
                                                    definition.parameters(self.max_speed_mps)),
                                      name=name, description=definition.description(lane), structured_output=False)
            tool.parameters["additionalProperties"] = False  # unknown arguments are an error, not ignored
            built.append(tool)
        return built

    # ------------------------------------------------------------------ notifications
    def publish_tactics(self) -> None:
        """Notify listeners that ``mpc://tactics`` changed (a tactic started or ended)."""
        if self.bus.listener_count:
            self.bus.publish_threadsafe(ResourceUpdated(uri=TACTICS_URI))

    def publish_observation(self, observation: dict[str, Any] | None = None) -> None:
        """Notify listeners that the observation resources changed (call after each step, from any thread).

        Ego and traffic are announced at most every ``publish_interval_s`` of sim time; emergency vehicles
        and obstacles when their content changes.
        """
        if self.bus.listener_count == 0:
            return
        obs = observation if observation is not None else self.latest_observation()
        t = float(obs.get("time_s", 0.0))
        if t - self._last_published_s < self.publish_interval_s - 1e-9 and t >= self._last_published_s:
            return
        self._last_published_s = t
        for uri in (EGO_URI, TRAFFIC_URI):
            self.bus.publish_threadsafe(ResourceUpdated(uri=uri))
        for uri, key in ((EMERGENCY_VEHICLES_URI, "emergency_vehicles"), (OBSTACLES_URI, "obstacles")):
            content = json.dumps(obs.get(key, []), sort_keys=True, default=str)
            if content != self._last_static.get(uri) or (key == "emergency_vehicles" and obs.get(key)):
                self._last_static[uri] = content
                self.bus.publish_threadsafe(ResourceUpdated(uri=uri))


def _mcp_function(call: Callable[..., dict[str, Any]], parameters: list[inspect.Parameter]) -> Callable[..., Any]:
    """A function the SDK reads a tool from: ``parameters`` (the schema) and the request context; calling it
    runs ``call`` with the arguments and the request's scheduling metadata."""

    def run_tool(ctx: Context, **arguments: Any) -> CallToolResult:
        return _run(lambda at: call(**arguments, apply_at_s=at), ctx)

    context = inspect.Parameter("ctx", inspect.Parameter.KEYWORD_ONLY, annotation=Context)
    run_tool.__signature__ = inspect.Signature([*parameters, context], return_annotation=CallToolResult)
    run_tool.__annotations__ = {**{p.name: p.annotation for p in parameters}, "ctx": Context,
                                "return": CallToolResult}
    return run_tool


def _run(call: Callable[[float | None], dict[str, Any]], ctx: Context) -> CallToolResult:
    """Run one tool with the request's scheduling metadata; refusals become MCP tool errors."""
    meta = ctx.request_context.meta or {}
    apply_at = meta.get(APPLY_AT_META_KEY)
    if apply_at is not None and (isinstance(apply_at, bool) or not isinstance(apply_at, int | float)):
        raise ToolError(f"_meta {APPLY_AT_META_KEY} must be a number (sim time in s), got {apply_at!r}")
    try:
        result = call(None if apply_at is None else float(apply_at))
    except ToolCallError as error:
        raise ToolError(str(error)) from None
    return CallToolResult(content=[TextContent(type="text", text=to_json(result))], structured_content=result)


def build_server(
    tools: ControllerTools, latest_observation: ObservationSource, **options: Any
) -> AgenticMPCServer:
    """The MCP server over ``tools`` and ``latest_observation`` (see :class:`AgenticMPCServer`)."""
    return AgenticMPCServer(tools, latest_observation, **options)
