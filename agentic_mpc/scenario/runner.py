"""Run one scenario: build its world, initial specification and agent, hand them to the run loop, write
the run's files.

:func:`run_scenario` writes ``trajectory.csv``, ``events.csv``, ``traffic.csv``, ``summary.csv``,
``obstacles.csv``, ``obstacle_passes.csv``, ``transcript.jsonl``, ``scenario.json``, ``trajectory.png`` and
``replay.html`` (the animated replay, :mod:`agentic_mpc.replay`) to the output directory;
what was recorded is written even when the run fails, and the error is raised afterwards.
"""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

from agentic_mpc.scenario.schema import Scenario, load_scenario
from agentic_mpc.world.base import World

logger = logging.getLogger(__name__)


def build_world(scenario: Scenario) -> World:
    """The scenario's world, started by its kind (agentic_mpc/worlds.py; SUMO is launched here)."""
    from agentic_mpc.reproducibility import warn_once
    from agentic_mpc.worlds import WORLD_KINDS

    warn_once()  # where identical numbers across machines cannot be promised, the run's log says so
    return WORLD_KINDS[scenario.world_kind].start_world(scenario.world, scenario.seed)


def build_loop(scenario: Scenario, world: World, *, embedded_agent: bool = True, pace: float | None = None,
               transcript_path: Path | None = None, server_options: dict[str, Any] | None = None,
               agent: Any = None) -> Any:
    """The run loop of ``scenario`` over ``world``; with ``embedded_agent`` its agent is started: the
    scenario's, or ``agent`` (an :class:`~agentic_mpc.run.loop.AgentSetup`) if given."""
    from agentic_mpc.run.loop import AgentSetup, LoopSettings, RunLoop
    from agentic_mpc.scenario.specification import initial_specification, steering_template

    settings = scenario.agent
    if pace is None and embedded_agent and settings.mode == "realtime":
        pace = 1.0  # a realtime agent's latency must cost the car sim time, as it would on the road
    if not embedded_agent:
        agent = None
    elif agent is None:
        agent = AgentSetup(settings.build_backend(world.lanes().lefthand),
                           settings.agent_config(transcript_path=transcript_path))
    return RunLoop(
        world, initial_specification(scenario.specification, world),
        LoopSettings(duration_s=scenario.duration_s, stop_at_goal=scenario.stop_at_goal,
                     traffic_stride=scenario.outputs.traffic_stride, pace=pace,
                     alert_distance_m=settings.alert_distance_m,
                     plan_stride=scenario.outputs.plan_stride if scenario.outputs.replay else 0),
        controller=scenario.controller, seed=scenario.seed, messages=scenario.messages, agent=agent,
        steering_template=steering_template(scenario.specification),
        server_options={**{key: value for key in ("jurisdiction", "road_type")
                           if (value := getattr(scenario, key)) is not None},
                        **(server_options or {})},
        tactics=scenario.tactics,
    )


class ScenarioRun:
    """One run of one scenario variant with one seed; :meth:`run` drives it to the end.

    ``embedded_agent=False`` leaves the agent's part to an outside MCP host (``agentic-mpc serve``): the
    timeline's messages are not delivered and tool calls apply when they arrive. ``pace`` > 0 runs the
    simulation at ``pace`` wall seconds per simulated second (1 = real time) instead of as fast as it goes.
    ``ready`` is set once :attr:`loop` (and its MCP server) exists; setting ``stop`` ends the run early
    (files are written).
    """

    def __init__(self, scenario: Scenario, out_dir: Path, *, embedded_agent: bool = True, pace: float | None = None,
                 server_options: dict[str, Any] | None = None) -> None:
        self.scenario = scenario
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.embedded_agent = embedded_agent
        self.pace = pace
        self.server_options = server_options or {}
        self.error: BaseException | None = None
        self.loop: Any = None
        self.ready = threading.Event()
        self.stop = threading.Event()

    @property
    def server(self) -> Any:
        return self.loop.server if self.loop is not None else None

    def run(self) -> dict[str, Any]:
        started = time.perf_counter()
        transcript_path = self.out_dir / "transcript.jsonl"
        transcript_path.unlink(missing_ok=True)
        try:
            world = build_world(self.scenario)
        except BaseException as error:
            self.error = error
            self.ready.set()
            raise
        try:
            self.loop = build_loop(self.scenario, world, embedded_agent=self.embedded_agent, pace=self.pace,
                                   transcript_path=transcript_path, server_options=self.server_options)
            self.loop.stop = self.stop
            if self.loop.settings.pace:  # paced: the first step must not stall the clock (nor MCP readers)
                self.loop.warm_up()
            self.ready.set()
            self.loop.run()
        except BaseException as error:  # keep what was recorded, then re-raise
            self.error = error
            raise
        finally:
            self.ready.set()  # also on failure: nobody waits forever
            if self.loop is not None:
                self.loop.close()
                summary = self._write(time.perf_counter() - started)
            else:
                world.close()
        return summary

    def _write(self, wall_s: float) -> dict[str, Any]:
        scenario, loop = self.scenario, self.loop
        identity = {"scenario": scenario.name, "variant": scenario.variant, "seed": scenario.seed}
        summary = loop.recorder.write(self.out_dir, identity, loop.transcript, wall_s, self.error)
        (self.out_dir / "scenario.json").write_text(scenario.model_dump_json(indent=2), encoding="utf-8")
        if scenario.outputs.plot and loop.recorder.trajectory_rows:
            from agentic_mpc.plots import run_figure

            try:
                run_figure(self.out_dir, loop.world, loop.recorder.metrics,
                           title=f"{scenario.name} / {scenario.variant} / seed {scenario.seed}")
            except Exception:  # a figure must never cost the results
                logger.exception("could not draw %s", self.out_dir / "trajectory.png")
        if scenario.outputs.replay and loop.recorder.trajectory_rows:
            from agentic_mpc.replay import write_replay

            try:
                write_replay(self.out_dir)
            except Exception:  # nor must the replay
                logger.exception("could not write %s", self.out_dir / "replay.html")
        return summary


def run_scenario(scenario: Scenario, out_dir: Path) -> dict[str, Any]:
    """Run one scenario (variant and seed already chosen) into ``out_dir``; returns the summary row."""
    return ScenarioRun(scenario, out_dir).run()


def _with_replay(scenario: Scenario, replay: bool) -> Scenario:
    return scenario.model_copy(update={"outputs": scenario.outputs.model_copy(update={"replay": replay})})


def run_to_directory(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """The batch runner's unit of work: load, pick the variant, set the seed, run (no replay page: batches
    stay fast; see :func:`run_to_directory_with_replay`)."""
    scenario = load_scenario(scenario_file).variant(variant).with_seed(seed)
    return run_scenario(_with_replay(scenario, False), out_dir)


def run_to_directory_with_replay(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """:func:`run_to_directory` that also writes each run's ``replay.html`` (``agentic-mpc batch --replay``)."""
    scenario = load_scenario(scenario_file).variant(variant).with_seed(seed)
    return run_scenario(_with_replay(scenario, True), out_dir)


def drive(scenario: Scenario) -> Any:
    """Run ``scenario`` in this process without writing files (the demo, tests); returns the closed
    :class:`~agentic_mpc.run.loop.RunLoop` with its recorder. No replay is written, so no plan is recorded."""
    outputs = scenario.outputs.model_copy(update={"replay": False})
    loop = build_loop(scenario.model_copy(update={"outputs": outputs}), build_world(scenario))
    try:
        loop.run()
    finally:
        loop.close()
    return loop
