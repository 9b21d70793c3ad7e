"""Running the suite: each case goes to a fresh agent (an empty history) over its world at the start, with
the world's initial specification restored first.

A world is built once (``scenario.runner.build_world`` + ``build_loop``, as ``agentic-mpc ask`` does; the run
never advances) and kept for all the cases on it: only the specification is reset between cases, which is
what the agent changes. Cases run grouped by world, one world alive at a time (a process holds one SUMO
simulation), and come back in suite order. The agent talks to the loop's MCP server in process, in
``realtime`` timing: a call applies when the server accepts it, so the next turn of a dialogue starts
from the changed specification.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.base import Backend, BackendReply
from agentic_mpc.agent.hosting import SEPARATOR
from agentic_mpc.agent_eval.scoring import judge, sort_attempts
from agentic_mpc.agent_eval.suite import Case, Suite, SuiteError, WorldRef

logger = logging.getLogger(__name__)

BackendFactory = Callable[[bool], Backend]
"""A backend for one case, given whether its road is left-hand (the rules backend's yield lane). The agent
closes it after the case: lend a shared one (a loaded model) through :class:`KeepOpen`."""


class KeepOpen:
    """A backend lent to one agent: the agent closes what it is given on exit, the caller closes the real one
    (a model is loaded once for the whole suite)."""

    def __init__(self, backend: Backend) -> None:
        self.backend, self.name = backend, backend.name

    def __getattr__(self, attribute: str) -> Any:  # whatever else the agent asks of a backend: the real one's
        return getattr(self.backend, attribute)

    async def complete(self, history, tools) -> BackendReply:
        return await self.backend.complete(history, tools)

    async def aclose(self) -> None:
        return None


@dataclass
class TurnResult:
    """One turn of one case: what the agent did and the verdict."""

    case_id: str
    category: str
    world: str
    turn: int
    turns: int
    message: str
    expected: str
    calls: list[dict[str, Any]]
    answer: str
    ended: str
    right: bool
    detail: str
    latency_s: float
    repeats: int = 0
    unparsed: list[str] = field(default_factory=list)
    invalid: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    v_ref_before_mps: float | None = None
    answers: int = 0
    """Backend answers in the step."""
    prompt_tokens: int = 0
    """Prompt tokens the model processed (those it had cached not counted), as its server reported them."""
    cached_tokens: int = 0
    generated_tokens: int = 0
    model_s: float | None = None
    """The model server's own time for those tokens (llama.cpp's timings; None: the server did not say)."""

    @property
    def wall_per_model(self) -> float | None:
        """The turn's wall time over the model's own time: what the agent adds to what the tokens cost."""
        return None if not self.model_s else self.latency_s / self.model_s


@dataclass
class CaseResult:
    case: Case
    turns: list[TurnResult]

    @property
    def right(self) -> bool:
        return all(t.right for t in self.turns) and len(self.turns) == len(self.case.turns)


class EvalWorld:
    """A scenario's world at its start, its run loop (never stepped) and MCP server, reset between cases."""

    def __init__(self, ref: WorldRef) -> None:
        from agentic_mpc.scenario.runner import build_loop, build_world
        from agentic_mpc.scenario.schema import load_scenario

        self.ref = ref
        scenario = load_scenario(ref.scenario).variant(ref.variant)
        self.world = build_world(scenario)
        try:
            self.loop = build_loop(scenario, self.world, embedded_agent=False)
        except BaseException:
            self.world.close()
            raise
        self.initial = self.loop.slot.current
        self.lefthand = bool(self.world.lanes().lefthand)
        self.others: dict[str, Any] = {}
        if ref.knowledge:
            from agentic_mpc.knowledge.server import build_knowledge_server
            from agentic_mpc.knowledge.store import KnowledgeBase

            self.others["knowledge"] = build_knowledge_server(KnowledgeBase())

    def reset(self) -> None:
        """Back to the scenario's initial specification (the only state a case changes)."""
        self.loop.slot.replace(self.initial)

    def v_ref_mps(self) -> float | None:
        tracking = self.loop.slot.current.get("path_tracking")
        return None if tracking is None else float(tracking.v_ref_mps)

    def close(self) -> None:
        self.loop.close()


def suite_agent_config(settings: Any) -> AgentConfig:
    """The agent's configuration for the suite from its settings (an ``AgentSettings``): realtime, and two
    backend attempts, as ``ask`` has."""
    return settings.agent_config(mode="realtime", backend_attempts=2, retry_backoff_s=0.2)


def _check_tools(cases: Sequence[Case], listed: set[str], suite: Suite) -> None:
    problems = []
    for case in cases:
        for turn in case.turns:
            for option in turn.options:
                for spec in option:
                    unknown = [t for t in spec.tools if t not in listed]
                    if unknown:
                        problems.append(f"{suite.path}: case {case.id!r}: the server lists no tool {unknown[0]!r} "
                                        f"(tools: {', '.join(sorted(listed))})")
    if problems:
        raise SuiteError(sorted(set(problems)))


def run_case(case: Case, world: EvalWorld, backend: Backend, config: AgentConfig) -> CaseResult:
    """One case: a fresh agent over ``world`` from its initial specification, every turn delivered and judged."""
    world.reset()
    results: list[TurnResult] = []
    with Agent(backend, world.loop.server, config, other_servers=world.others) as agent:
        agent.warmed.wait(config.backend_timeout_s)  # as in a run: the model read the system message at the start
        listed = {tool.name for tool in agent.tools}
        wait_s = config.backend_timeout_s * config.backend_attempts * config.max_rounds_per_step + 30.0
        for index, turn in enumerate(case.turns):
            v_before = world.v_ref_mps()
            started, seen = time.perf_counter(), len(agent.history)
            report = agent.deliver(turn.message).result(timeout=wait_s)
            said = " ".join(m.content for m in agent.history.messages[seen:] if m.role == "assistant" and m.content)
            latency_s = time.perf_counter() - started
            # a knowledge search changes nothing: what is scored is the calls to the car and the answer
            to_car = [call for call in report.tool_calls if SEPARATOR not in str(call.get("tool"))]
            attempts = sort_attempts(to_car, listed)
            verdict = judge(turn, attempts, v_before, backend_failed=report.ended == "backend_error",
                            answer=said)  # every answer of the step: the citation may precede its last
            results.append(TurnResult(
                case.id, case.category, case.world, index + 1, len(case.turns), turn.message,
                turn.describe(v_before), list(attempts.accepted), report.text, report.ended, verdict.right,
                verdict.detail, round(latency_s, 3), attempts.repeats, list(attempts.unparsed),
                list(attempts.invalid), list(report.errors), v_before, report.usage.answers,
                report.usage.prompt_tokens, report.usage.cached_tokens, report.usage.generated_tokens,
                None if report.usage.model_s is None else round(report.usage.model_s, 3),
            ))
    return CaseResult(case, results)


def run_suite(suite: Suite, cases: Sequence[Case], make_backend: BackendFactory, config: AgentConfig,
              progress: Callable[[CaseResult, int, int], None] | None = None) -> list[CaseResult]:
    """Every case of ``cases`` (see the module docstring); ``progress(result, done, total)`` after each."""
    order = list(dict.fromkeys(case.world for case in cases))
    by_case: dict[str, CaseResult] = {}
    done = 0
    for name in order:
        world = EvalWorld(suite.worlds[name])
        try:
            checked = False
            for case in (c for c in cases if c.world == name):
                backend = make_backend(world.lefthand)  # per case: a fresh backend state (and event loop)
                if not checked:  # the suite's tool names against what this server lists
                    with Agent(KeepOpen(backend), world.loop.server, config, other_servers=world.others) as probe:
                        # this world's cases only: a two-lane road has no centre lane tool
                        _check_tools([c for c in cases if c.world == name], {t.name for t in probe.tools}, suite)
                    checked = True
                result = run_case(case, world, backend, config)
                by_case[case.id] = result
                done += 1
                if progress is not None:
                    progress(result, done, len(cases))
        finally:
            world.close()
    return [by_case[case.id] for case in cases]
