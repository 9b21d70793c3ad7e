"""Run one scenario: the SUMO co-simulation, the MCP server over it, the agent, the message timeline.

Per control step at simulation time t:

1. lockstep tool calls whose time has come take effect (``ControllerTools.apply_due``);
2. user messages due at t (by time, or a delay after an event SUMO showed) go to the agent; in lockstep
   mode the simulation waits for the agent (sim time is frozen, its latency is charged in sim time), in
   realtime mode it does not;
3. one co-simulation step (observation -> controller -> bicycle model -> SUMO);
4. the MCP server announces the new observation; the agent may wake on it (observation messages);
5. metrics and traffic rows are recorded.

:func:`run_scenario` writes ``trajectory.csv``, ``events.csv``, ``traffic.csv``, ``summary.csv``,
``transcript.jsonl`` and ``trajectory.png`` to the output directory; what was recorded is written even when
the run fails, and the error is raised afterwards.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import pandas as pd

from agentic_mpc.agent.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend, OpenAIConfig
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.observations import EmergencyWatchConfig
from agentic_mpc.mcp_server import AgenticMPCServer, build_server
from agentic_mpc.primitives import (
    Mandatory,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
    SpecificationSlot,
)
from agentic_mpc.scenario.events import EmergencyEvents, MessageSchedule
from agentic_mpc.scenario.metrics import MetricsRecorder, ObstacleTrack, summarise
from agentic_mpc.scenario.schema import AgentSettings, Scenario, SpecificationSettings, load_scenario
from agentic_mpc.sumo.cosimulation import CoSimulation
from agentic_mpc.tools import ControllerTools, RoadLanes

logger = logging.getLogger(__name__)

TRAFFIC_COLUMNS = ("time_s", "id", "type_id", "vclass", "x_m", "y_m", "heading_rad", "speed_mps", "lane_id",
                   "road_s_m", "gap_m", "relation", "emergency")


def specification_for(settings: SpecificationSettings, road: Any, obstacle_circles: tuple[Any, ...]) -> Specification:
    """The scenario's initial attachment, with lanes resolved on ``road`` and J2 over ``obstacle_circles``."""
    primitives: list[Any] = []
    if settings.path_tracking is not None:
        tracking = settings.path_tracking
        index = road.lane_index(tracking.lane)
        options = tracking.model_dump(exclude={"lane", "paper_reference"}, exclude_none=True)
        if tracking.paper_reference:
            options["reference_accel_mps2"] = None
        primitives.append(PathTracking(path=road.lane_paths[index], lane=road.lane_role(index), **options))
    if settings.obstacle_avoidance is not None and obstacle_circles:
        primitives.append(ObstacleAvoidance(obstacles=obstacle_circles, penalty=settings.obstacle_avoidance.penalty))
    if settings.preferred_steering_direction is not None:
        primitives.append(PreferredSteeringDirection.model_validate(settings.preferred_steering_direction))
    return Specification.of(*primitives, mandatory=Mandatory.model_validate(settings.mandatory))


def initial_specification(settings: SpecificationSettings, cosim: CoSimulation) -> Specification:
    """The initial attachment on the co-simulation's road, J2 over the obstacles as SUMO placed them."""
    return specification_for(settings, cosim.road, cosim.obstacle_circles(only_in_j2=True))


def road_lanes(cosim: CoSimulation) -> RoadLanes:
    """The ego road's lanes by role and its speed limit (the lowest on the road), for the tools."""
    lanes = {role: cosim.road.lane_paths[index] for role, index in cosim.road.lane_roles().items()}
    limit = min(cosim.network.edge(edge_id).getSpeed() for edge_id in cosim.road.edge_ids)
    return RoadLanes(lanes, float(limit))


def build_backend(settings: AgentSettings, lefthand: bool) -> Any:
    """The scenario's backend; the rules backend pulls over to the road edge (left in left-hand traffic)."""
    if settings.backend == "rules":
        return RulesBackend(yield_lane="left" if lefthand else "right")
    return OpenAIBackend(
        OpenAIConfig(
            base_url=settings.base_url, model=settings.model, api_key_env=settings.api_key_env,
            timeout_s=settings.timeout_s,
        )
    )


class ScenarioRun:
    """One run of one scenario variant with one seed; :meth:`run` drives it to the end.

    ``embedded_agent=False`` leaves the agent's part to an outside MCP host (``agentic-mpc serve``): the
    timeline's messages are not delivered and tool calls apply when they arrive. ``pace`` > 0 runs the
    simulation at ``pace`` wall seconds per simulated second (1 = real time) instead of as fast as it goes.
    ``ready`` is set once :attr:`server` exists; setting ``stop`` ends the run early (files are written).
    """

    def __init__(self, scenario: Scenario, out_dir: Path, *, embedded_agent: bool = True, pace: float | None = None,
                 server_options: dict[str, Any] | None = None) -> None:
        self.scenario = scenario
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.embedded_agent = embedded_agent
        self.pace = pace
        self.server_options = server_options or {}
        self.trajectory_rows: list[dict[str, Any]] = []
        self.traffic_rows: list[dict[str, Any]] = []
        self.specification_events: list[dict[str, Any]] = []
        self.recorder = MetricsRecorder()
        self.error: BaseException | None = None
        self.server: AgenticMPCServer | None = None
        self.ready = threading.Event()
        self.stop = threading.Event()

    def run(self) -> dict[str, Any]:
        started = time.perf_counter()
        scenario = self.scenario
        config = scenario.simulation.replace(seed=scenario.seed, controller_seed=None)
        transcript_path = self.out_dir / "transcript.jsonl"
        transcript_path.unlink(missing_ok=True)
        cosim = CoSimulation(config)
        agent: Agent | None = None
        try:
            cosim.slot = SpecificationSlot(initial_specification(scenario.specification, cosim))
            cosim.slot.subscribe(
                lambda spec, version: self.specification_events.append(
                    {"event": "specification", "sim_time_s": round(cosim.time_s, 3), "tau": None,
                     "result": json.dumps({"version": version, "attached": spec.summary()})}
                )
            )
            tools = ControllerTools(cosim.slot, lambda: road_lanes(cosim), self._steering_template())
            server = build_server(tools, lambda: cosim.observation.to_json(), **self.server_options)
            self.server = server
            if self.embedded_agent:
                agent = self._start_agent(server, transcript_path, lambda: cosim.time_s, cosim.road.lefthand)
            self.ready.set()
            self._track_obstacles(cosim)
            events = EmergencyEvents(scenario.agent.alert_distance_m)
            schedule = MessageSchedule(scenario.messages, events)
            self._loop(cosim, tools, server, agent, events, schedule)
        except BaseException as error:  # keep what was recorded, then re-raise
            self.error = error
            raise
        finally:
            self.ready.set()  # also on failure: nobody waits forever
            if agent is not None:
                agent.close()
            cosim.close()
            summary = self._write(cosim, agent, time.perf_counter() - started)
        return summary

    def _steering_template(self) -> PreferredSteeringDirection | None:
        j3 = self.scenario.specification.preferred_steering_direction
        return PreferredSteeringDirection.model_validate(j3) if j3 else None

    def _start_agent(self, server: AgenticMPCServer, transcript: Path, clock: Any, lefthand: bool) -> Agent:
        settings = self.scenario.agent
        config = AgentConfig(
            timing=settings.mode,
            latency_s=settings.latency_s,
            transcript_path=transcript,
            wake_on_emergency_vehicles=settings.observation_messages,
            emergency_watch=EmergencyWatchConfig(distance_m=settings.alert_distance_m),
            backend_timeout_s=settings.timeout_s,
        )
        return Agent(build_backend(settings, lefthand), server, config, sim_clock=clock).start()

    def _track_obstacles(self, cosim: CoSimulation) -> None:
        assert cosim.observation is not None
        circles = cosim.obstacle_circles()
        for obstacle in cosim.observation.obstacles:
            own = tuple(c for c in circles if c.label == obstacle.id)
            self.recorder.obstacles.append(ObstacleTrack(obstacle.id, own, obstacle.road_s_m, obstacle.lane_index))

    def _loop(self, cosim: CoSimulation, tools: ControllerTools, server: AgenticMPCServer, agent: Agent | None,
              events: EmergencyEvents, schedule: MessageSchedule) -> None:
        scenario = self.scenario
        stride = scenario.outputs.traffic_stride
        end_s = scenario.duration_s - 1e-9
        lockstep = scenario.agent.mode == "lockstep"
        step = 0
        wall_start, sim_start = time.perf_counter(), cosim.time_s
        while cosim.time_s < end_s and not (scenario.stop_at_goal and cosim.reached_goal) and not self.stop.is_set():
            t = cosim.time_s
            if self.pace:  # real time for an outside MCP host: the simulation waits for the wall clock
                time.sleep(max(0.0, wall_start + (t - sim_start) * self.pace - time.perf_counter()))
            tools.apply_due(t)
            for message in schedule.due(t) if agent is not None else ():
                reply = agent.deliver(message.text, sim_time_s=t)
                if lockstep:
                    reply.result()
                tools.apply_due(t)  # a zero-latency lockstep call applies now
            specification = cosim.slot.current
            record = cosim.step()
            observation = cosim.observation
            assert observation is not None
            server.publish_observation(observation.to_json())
            if agent is not None and scenario.agent.observation_messages:
                for reply in agent.observe(observation.to_json()):
                    if lockstep:
                        reply.result()
            events.update(observation)
            self._record(cosim, record, specification, observation, step % stride == 0)
            step += 1

    def _record(self, cosim: CoSimulation, record: Any, specification: Specification, observation: Any,
                with_traffic: bool) -> None:
        row = asdict(record)
        tracking = specification.get("path_tracking")
        if isinstance(tracking, PathTracking):
            row["tracked_lane"] = tracking.lane
            row["v_ref_mps"] = tracking.v_ref_mps
            row["tracked_lane_offset_m"] = float(tracking.path.lateral_offset(record.x_m, record.y_m)[0])
        else:
            row["tracked_lane"], row["v_ref_mps"], row["tracked_lane_offset_m"] = "", float("nan"), float("nan")
        self.trajectory_rows.append(row)
        self.recorder.observe(
            observation, lambda index, x, y: float(cosim.road.lane_paths[index].lateral_offset(x, y)[0])
        )
        for emergency in observation.emergency_vehicles:
            self.recorder.record_time_loss(emergency.vehicle.id, cosim.bridge.time_loss_s(emergency.vehicle.id))
        if with_traffic:
            emergency_ids = {e.vehicle.id for e in observation.emergency_vehicles}
            others = {v.id: v for v in observation.traffic}
            others.update({e.vehicle.id: e.vehicle for e in observation.emergency_vehicles})
            for vehicle in others.values():
                self.traffic_rows.append(
                    {
                        "time_s": observation.time_s, "id": vehicle.id, "type_id": vehicle.type_id,
                        "vclass": vehicle.vclass, "x_m": vehicle.x_m, "y_m": vehicle.y_m,
                        "heading_rad": vehicle.heading_rad, "speed_mps": vehicle.speed_mps,
                        "lane_id": vehicle.lane_id, "road_s_m": vehicle.road_s_m, "gap_m": vehicle.gap_m,
                        "relation": vehicle.relation, "emergency": vehicle.id in emergency_ids,
                    }
                )

    def _write(self, cosim: CoSimulation, agent: Agent | None, wall_s: float) -> dict[str, Any]:
        from agentic_mpc.scenario.plots import run_figure

        trajectory = pd.DataFrame(self.trajectory_rows)
        trajectory.to_csv(self.out_dir / "trajectory.csv", index=False)
        pd.DataFrame(self.traffic_rows, columns=list(TRAFFIC_COLUMNS)).to_csv(self.out_dir / "traffic.csv", index=False)
        transcript = agent.transcript.records if agent is not None else []
        events = events_table(sorted(transcript + self.specification_events,
                                     key=lambda r: (r.get("sim_time_s") is None, r.get("sim_time_s") or 0.0)))
        events.to_csv(self.out_dir / "events.csv", index=False)
        scenario = self.scenario
        summary: dict[str, Any] = {
            "scenario": scenario.name,
            "variant": scenario.variant,
            "seed": scenario.seed,
            "status": "ok" if self.error is None else "failed",
            "error": "" if self.error is None else f"{type(self.error).__name__}: {self.error}",
        }
        summary.update(
            summarise(trajectory, self.recorder, goal_s_m=cosim.goal_s_m,
                      agent_tool_calls=int((events["event"] == "tool_call").sum()) if len(events) else 0)
        )
        summary["wall_s"] = round(wall_s, 3)
        pd.DataFrame([summary]).to_csv(self.out_dir / "summary.csv", index=False)
        (self.out_dir / "scenario.json").write_text(scenario.model_dump_json(indent=2), encoding="utf-8")
        pd.DataFrame(
            [(c.label, c.x_m, c.y_m, c.radius_m) for track in self.recorder.obstacles for c in track.circles],
            columns=["id", "x_m", "y_m", "radius_m"],
        ).to_csv(self.out_dir / "obstacles.csv", index=False)
        if scenario.outputs.plot and len(trajectory):
            try:
                run_figure(self.out_dir, cosim.road, self.recorder, title=f"{scenario.name} / {scenario.variant} / seed {scenario.seed}")
            except Exception:  # a figure must never cost the results
                logger.exception("could not draw %s", self.out_dir / "trajectory.png")
        return summary


def events_table(transcript: list[dict[str, Any]]) -> pd.DataFrame:
    """The transcript as one row per message, tool call and result, with tau and simulation time."""
    columns = ["event", "tau", "sim_time_s", "role", "source", "content", "tool", "arguments", "ok", "result",
               "error", "apply_at_s"]
    rows = []
    for record in transcript:
        row = {key: record.get(key) for key in columns}
        for key in ("arguments", "result"):
            if row[key] is not None and not isinstance(row[key], str):
                row[key] = json.dumps(row[key], default=str)
        rows.append(row)
    return pd.DataFrame(rows, columns=columns)


def dry_specification(scenario: Scenario) -> tuple[Specification, RoadLanes, bool]:
    """The initial specification, the road's lanes and whether it is left-hand, from the network alone
    (no simulation: obstacles are placed where the scenario puts them, as 2.5 m discs)."""
    from agentic_mpc.primitives import Circle
    from agentic_mpc.sumo.network import RoadNetwork

    simulation = scenario.simulation
    network = RoadNetwork(simulation.net_file)
    road = network.road(simulation.road)
    circles = []
    for obstacle in simulation.obstacles if scenario.specification.obstacle_avoidance is not None else ():
        if obstacle.in_j2:
            edge = obstacle.edge_id or road.edge_ids[0]
            x, y, _ = road.pose_on_lane(f"{edge}_{road.lane_index(obstacle.lane)}", obstacle.pos_m)
            circles.append(Circle(x_m=x, y_m=y, radius_m=2.5, label=obstacle.id))
    specification = specification_for(scenario.specification, road, tuple(circles))
    lanes = {role: road.lane_paths[index] for role, index in road.lane_roles().items()}
    limit = min(network.edge(edge_id).getSpeed() for edge_id in road.edge_ids)
    return specification, RoadLanes(lanes, float(limit)), road.lefthand


def run_scenario(scenario: Scenario, out_dir: Path) -> dict[str, Any]:
    """Run one scenario (variant and seed already chosen) into ``out_dir``; returns the summary row."""
    return ScenarioRun(scenario, out_dir).run()


def run_to_directory(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """The batch runner's unit of work: load, pick the variant, set the seed, run."""
    scenario = load_scenario(scenario_file).variant(variant).with_seed(seed)
    return run_scenario(scenario, out_dir)


