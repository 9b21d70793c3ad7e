"""The car never waits for the agent: control step times while a slow model thinks, in real time."""

from __future__ import annotations

import statistics
import threading
import time
from dataclasses import dataclass

import numpy as np
import pytest

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import OpenAISettings
from tests.agent.conftest import paper_start_config, plain_loop
from tests.agent.scripted_llm import Delay, ScriptedLLM, calls, text, tool_call

THINK_S = 3.0
pytestmark = pytest.mark.timing  # step lateness in real time: alone, not beside other tests


@dataclass
class StepTiming:
    time_s: float
    compute_ms: float
    """The loop's step: specification snapshot, surroundings, MPPI solve, the world's advance."""
    late_ms: float
    """How much later than its tick the step started."""


def _stats(values: list[float]) -> dict[str, float]:
    return {
        "n": len(values),
        "median": round(statistics.median(values), 3),
        "p95": round(float(np.percentile(values, 95)), 3),
        "max": round(max(values), 3),
    }


def _timed(loop) -> list[tuple[float, float, float]]:
    """Record (sim time, wall start, step ms) of every step the loop takes from now on."""
    records: list[tuple[float, float, float]] = []
    step = loop.step

    def timed_step():
        t, started = loop.world.time_s, time.perf_counter()
        outcome = step()
        records.append((t, started, outcome.step_ms))
        return outcome

    loop.step = timed_step
    return records


def test_control_steps_are_unchanged_while_the_agent_thinks():
    script = [Delay(THINK_S, calls(tool_call("run_left_lane", {"v_ref": 0}))), text("Done.")]
    with ScriptedLLM(script) as llm, plain_loop(paper_start_config(), pace=1.0) as loop:
        world = loop.world
        backend = OpenAIBackend(OpenAISettings(base_url=llm.base_url, api_key_env=None, timeout_s=30))
        with Agent(backend, loop.server, AgentConfig(), sim_clock=lambda: world.time_s) as agent:
            loop.step()  # compile before timing
            records = _timed(loop)
            driving = threading.Thread(target=loop.run, name="run-loop", daemon=True)  # real time
            driving.start()
            time.sleep(1.5)
            sent_at = world.time_s
            future = agent.deliver("An ambulance is coming behind us. We'd better let them pass.")
            assert not future.done()  # deliver returned at once
            report = future.result(THINK_S + 10)
            time.sleep(1.0)
            loop.stop.set()
            driving.join(5)

    assert report.applied_calls == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    (call,) = agent.transcript.events("tool_call")
    # the car drove on the old specification for the whole thinking time
    assert call["sim_time_s"] - sent_at >= THINK_S - 0.1

    t0, wall0, _ = records[0]  # the first tick of the paced run starts on time
    timings = [StepTiming(t, ms, max(0.0, (started - (wall0 + (t - t0))) * 1e3)) for t, started, ms in records]
    baseline = [s for s in timings if 0.3 <= s.time_s < sent_at]
    thinking = [s for s in timings if sent_at + 0.2 <= s.time_s < sent_at + THINK_S - 0.2]
    assert len(thinking) >= (THINK_S - 0.4) / world.dt_s - 2  # every tick happened: nobody waited
    compute_before = _stats([s.compute_ms for s in baseline])
    compute_during = _stats([s.compute_ms for s in thinking])
    late_during = _stats([s.late_ms for s in thinking])
    print(f"\ncompute ms before: {compute_before}\ncompute ms while thinking: {compute_during}\n"
          f"start lateness ms while thinking: {late_during}")
    assert compute_during["median"] <= 1.5 * compute_before["median"] + 0.5
    assert late_during["p95"] < 20.0  # a step is 40 ms: starting 20 ms late would still meet it
    assert compute_during["p95"] < 40.0
