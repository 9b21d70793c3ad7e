"""The one run loop: it owns the controller, the specification slot, the tools, the MCP server, the agent,
the message timeline and the recorder, and steps any :class:`~agentic_mpc.world.base.World`.

One control step at simulation time t (:meth:`RunLoop.step`):

1. lockstep tool calls whose time has come take effect (``ControllerTools.apply_due``);
2. the timeline's messages due at t (by time, or a delay after an emergency-vehicle event) go to the agent;
   in lockstep mode the loop waits for the agent (sim time is frozen, its latency is charged in sim time),
   in realtime mode it does not;
3. one snapshot of the specification; the world's surroundings; the controller's inputs;
4. the world advances one step with those inputs (the plant moves, the traffic reacts);
5. the run's one emergency detector (:mod:`agentic_mpc.world.emergency`) decides whether an emergency
   vehicle is approaching or has passed; the MCP server announces the new observation, and lists those
   events in ``sumo://emergency-vehicles``; an agent with observation messages reads them there and wakes
   itself on each (lockstep: told to read here, the loop waits; realtime: subscribed to the resource's
   updates); the step is recorded;
   every 0.2 s the world is told the controller's plan (``World.signal_intention``: SUMO's drivers let the
   ego into the lane it enters).

Every tool call the MCP server receives (from the embedded agent or an outside host) is recorded as it
arrives, with its client and the sim time (``tool_call_received`` in ``events.csv``).

``run``, ``batch``, ``serve`` and ``ask`` are all this loop: ``serve`` paces it to the wall clock and leaves
the agent's part to an outside MCP host, ``ask`` builds it and never advances.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.mcp.server import AgenticMPCServer, build_server
from agentic_mpc.mcp.tools import ControllerTools
from agentic_mpc.primitives import PreferredSteeringDirection, Specification, SpecificationSlot
from agentic_mpc.run.recorder import RunRecorder, StepOutcome
from agentic_mpc.run.timeline import MessageSchedule, TimedMessage
from agentic_mpc.tactics.config import TacticsConfig
from agentic_mpc.tactics.layer import TacticsLayer
from agentic_mpc.vehicle import PAPER_PARAMS, throttle_for_steady_speed
from agentic_mpc.world import ALERT_DISTANCE_M
from agentic_mpc.world.base import World
from agentic_mpc.world.emergency import EmergencyDetector
from agentic_mpc.world.lanes import situation_of

logger = logging.getLogger(__name__)

_ANNOUNCE_EVERY_STEPS = 5
"""How often the world is told the controller's plan (0.2 s at 0.04 s: SUMO's drivers react within a second)."""
LAG_WARNING_S = 0.5
"""A paced run more than this far behind the wall clock says once that it cannot keep real time."""


@dataclass(frozen=True)
class LoopSettings:
    """When a run ends and how it is paced."""

    duration_s: float
    """Simulation time at which the run ends (the world's clock, warm-up included)."""
    stop_at_goal: bool = True
    traffic_stride: int = 5
    """Record the other road users every this many steps."""
    pace: float | None = None
    """Wall seconds per simulated second (1 = real time; None: as fast as it goes)."""
    alert_distance_m: float = ALERT_DISTANCE_M
    """How far behind an emergency vehicle starts to matter (events and observation messages)."""
    plan_stride: int = 0
    """Record the controller's optimal predicted trajectory every this many steps (0: never)."""


@dataclass
class AgentSetup:
    """The embedded agent: a backend and how it runs (with ``config.observation_messages`` emergency events
    wake it)."""

    backend: Any
    config: Any
    """An :class:`~agentic_mpc.agent.agent.AgentConfig`."""


class RunLoop:
    """One run over ``world`` from ``specification`` (see the module docstring). Use as a context manager, or
    call :meth:`close`; :meth:`run` steps to the end, :meth:`step` one control step."""

    def __init__(
        self,
        world: World,
        specification: Specification,
        settings: LoopSettings,
        *,
        controller: MPPIConfig | None = None,
        seed: int = 0,
        messages: Sequence[TimedMessage] = (),
        agent: AgentSetup | None = None,
        steering_template: PreferredSteeringDirection | None = None,
        server_options: dict[str, Any] | None = None,
        tactics: TacticsConfig = TacticsConfig(),
    ) -> None:
        self.world = world
        self.settings = settings
        road = getattr(world, "tactical_road", None)  # a world that offers no road for the tactics drives without
        self.tactics = TacticsLayer(tactics, road) if road is not None else None
        self.controller = FourierMPPI(controller, params=getattr(world, "params", PAPER_PARAMS), seed=seed)
        mean = np.zeros((2, self.controller.config.coefficients))
        mean[1, 0] = throttle_for_steady_speed(float(world.ego_state[3]))  # start cruising, not coasting
        self.controller.reset(mean)
        self.recorder = RunRecorder(world, settings.traffic_stride)
        self.slot = SpecificationSlot(specification)
        self.slot.subscribe(self.recorder.specification_changed)
        self.tools = ControllerTools(self.slot, world.lanes, steering_template,
                                     situation_source=lambda: situation_of(world.observation))
        self.tools.route_planner = getattr(world, "route_planner", None)  # worlds with junctions: turn, drive to
        self._road_version = getattr(world, "road_version", 0)
        self.server: AgenticMPCServer = build_server(
            self.tools, self._observation_json,
            **{"lane_index": world.lane_index_of, **(server_options or {})},  # sumo://road: the world's lane indices
            tactics=self.tactics.to_json if self.tactics is not None else None,
            memory=lambda: self.agent.memory_json() if self.agent is not None else None,  # agent://memory
            route=self.tools.route_planner.describe if self.tools.route_planner is not None else None,
        )
        self.server.on_tool_call = self.recorder.tool_call_received  # who changed the specification
        self.detector = EmergencyDetector(settings.alert_distance_m)
        self.schedule = MessageSchedule(tuple(messages), self.detector)
        self.stop = threading.Event()
        """Set it (from any thread) to end :meth:`run` after the current step."""
        self.realtime_lag_s = 0.0
        """A paced run: the most the simulation fell behind the wall clock (0 when unpaced or on time)."""
        self.agent: Any = None
        self._observation_messages = False
        if agent is not None:
            from agentic_mpc.agent.agent import Agent

            config = agent.config  # observation messages: the detector's events, read by the agent over MCP
            others = {}
            if config.knowledge:  # the shipped knowledge server, in process (the agent knows it as a client)
                from agentic_mpc.knowledge.server import build_knowledge_server
                from agentic_mpc.knowledge.store import KnowledgeBase

                others["knowledge"] = build_knowledge_server(KnowledgeBase())
            self.agent = Agent(agent.backend, self.server, config, sim_clock=lambda: world.time_s,
                               other_servers=others).start()
            self._observation_messages = config.observation_messages
        self._lockstep = self.agent is not None and self.agent.config.mode == "lockstep"

    def _observation_json(self) -> dict[str, Any]:
        """What the observation resources read: the world's latest observation and the detector's events."""
        return {**self.world.observation.to_json(), "emergency_events": [e.to_json() for e in self.detector.events]}

    # ------------------------------------------------------------------ stepping
    @property
    def finished(self) -> bool:
        world, s = self.world, self.settings
        reached = s.stop_at_goal and world.observation.ego.road_s_m >= world.goal_s_m
        blocked = self.recorder.metrics.stuck.hopeless  # every lane blocked: the reason is in summary.csv
        return reached or blocked or world.time_s >= s.duration_s - 1e-9 or self.stop.is_set()

    def step(self) -> StepOutcome:
        """One control step (see the module docstring). Raises the world's error if it fails."""
        world = self.world
        t = world.time_s
        self.tools.apply_due(t)
        for message in self.schedule.due(t) if self.agent is not None else ():
            self.agent.deliver(message.text, sim_time_s=t)  # lockstep: returns when the agent is idle
            self.tools.apply_due(t)  # a zero-latency lockstep call applies now
        started = time.perf_counter()
        specification, version = self.slot.snapshot()
        before, state = world.observation, world.ego_state
        path = getattr(specification.get("path_tracking"), "path", None)
        plan = None
        if self.tactics is not None and getattr(world, "road_version", 0) != self._road_version:
            self._road_version = world.road_version  # the ego took another route: its road for the tactics
            self.tactics.retarget(world.tactical_road)
        if self.tactics is not None:  # between what the world observes and the controller
            side = getattr(specification.get("preferred_steering_direction"), "direction", None)
            plan = self.tactics.plan(before, world.lane_index_of(path), side)
            if self.tactics.changes:
                self.recorder.tactic_events += self.tactics.changes
                self.tactics.changes.clear()
                self.server.publish_tactics()
        surroundings = world.surroundings(self.controller.config.horizon, path, plan)
        output = self.controller.step(state, specification, surroundings)
        after = world.advance(output.delta, output.throttle, output.brake)
        outcome = StepOutcome(before, state, output, specification, version, len(surroundings.moving_discs),
                              (time.perf_counter() - started) * 1e3)
        events = self.detector.update(after)  # decided once: the timeline's and the agent's events
        self.server.publish_observation()  # after the detector: a listener reads this step's events
        if events and self._observation_messages and self._lockstep:  # the agent reads them; the car waits
            self.agent.watch(round(after.time_s, 3))
        self.recorder.step(outcome, after)
        steps = len(self.recorder.trajectory_rows) - 1
        stride = self.settings.plan_stride
        announce = steps % _ANNOUNCE_EVERY_STEPS == 0
        if announce or stride and steps % stride == 0:
            plan = self.controller.planned_states(state)
            if announce:
                world.signal_intention(plan[:, :2])
            if stride and steps % stride == 0:
                self.recorder.plan(before.time_s, plan)
        return outcome

    def warm_up(self) -> None:
        """Load the controller's compiled kernels with a throwaway controller (same settings, its own random
        stream: the run's is untouched), so that a paced run does not start a second behind the wall clock;
        and let the agent's model read its system message first (set-up, as loading the model is: a message
        in the first seconds would otherwise wait for it, tens of seconds on one CPU thread)."""
        spare = FourierMPPI(self.controller.config, params=self.controller.params, seed=0)
        spare.reset(self.controller.mean)
        spare.step(self.world.ego_state, self.slot.current, self.world.surroundings(spare.config.horizon, None))
        if self.agent is not None and not self.agent.warmed.is_set():
            started = time.perf_counter()
            logger.info("the car starts once the agent's model has read its system message")
            self.agent.warmed.wait(self.agent.config.backend_timeout_s)
            logger.info("the agent's model was ready after %.1f s", time.perf_counter() - started)

    def run(self) -> None:
        """Step until the end of the run, the goal (if it stops there) or :attr:`stop`."""
        pace = self.settings.pace
        wall_start, sim_start = time.perf_counter(), self.world.time_s
        warned = False
        while not self.finished:
            if pace:  # the simulation waits for the wall clock (a realtime agent or an outside MCP host)
                due = wall_start + (self.world.time_s - sim_start) * pace
                behind_s = time.perf_counter() - due
                self.realtime_lag_s = max(self.realtime_lag_s, behind_s)
                if behind_s > LAG_WARNING_S and not warned:
                    warned = True
                    logger.warning("the simulation cannot keep real time: %.2f s behind the wall clock at t = %.2f s",
                                   behind_s, self.world.time_s)
                if self.stop.wait(max(0.0, -behind_s)):
                    break
            self.step()

    # ------------------------------------------------------------------ closing
    @property
    def transcript(self) -> list[dict[str, Any]]:
        return self.agent.transcript.records if self.agent is not None else []

    def close(self) -> None:
        """Stop the agent and the world (idempotent); what was recorded stays."""
        if self.agent is not None:
            self.agent.close()
        self.world.close()

    def __enter__(self) -> RunLoop:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
