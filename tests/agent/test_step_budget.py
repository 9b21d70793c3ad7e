"""Steps that end and what they cost: the model's reported tokens and times, the step's time and token budget,
a call that undoes the one just made, and a history kept inside the model's context (a real HTTP server on
127.0.0.1 with scripted answers; agent/backend_calls.py, agent/backends/context.py)."""

from __future__ import annotations

import pytest

from agentic_mpc.agent import Agent, AgentConfig, Message
from agentic_mpc.agent.backends.base import ModelUsage
from agentic_mpc.agent.backends.context import ContextWindow, estimate_tokens
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.run.loop import AgentSetup
from tests.agent.conftest import paper_start_config, plain_loop
from tests.agent.scripted_llm import Delay, ScriptedLLM, calls, text, tool_call

LLAMA_TIMINGS = {"cache_n": 1200, "prompt_n": 60, "prompt_ms": 2000.0, "predicted_n": 20, "predicted_ms": 1500.0}


def backend(llm: ScriptedLLM, **options) -> OpenAIBackend:
    options.setdefault("confirmation", "model")  # every answer from the model, as these budgets count them
    return OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="m", api_key_env=None, **options))


def test_what_the_server_says_an_answer_cost_is_read():
    usage = ModelUsage.from_response({"timings": LLAMA_TIMINGS})
    assert (usage.prompt_tokens, usage.cached_tokens, usage.generated_tokens) == (60, 1200, 20)
    assert usage.model_s == pytest.approx(3.5)
    # other OpenAI-compatible servers: tokens in usage (cached ones apart), no times
    usage = ModelUsage.from_response({"usage": {"prompt_tokens": 300, "completion_tokens": 12,
                                                "prompt_tokens_details": {"cached_tokens": 250}}})
    assert (usage.prompt_tokens, usage.cached_tokens, usage.generated_tokens, usage.model_s) == (50, 250, 12, None)
    assert ModelUsage.from_response({"choices": []}) is None


def test_a_step_sums_its_answers_costs_into_the_report_and_the_transcript(loop, server, tmp_path):
    script = [calls(tool_call("run_left_lane", {"v_ref": 0})), text("Done.")]
    config = AgentConfig(transcript_path=tmp_path / "t.jsonl")
    with ScriptedLLM(script, timings=LLAMA_TIMINGS) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver("Make way for the ambulance.").result(30)
    assert report.usage.answers == 2 and report.usage.prompt_tokens == 120 and report.usage.generated_tokens == 40
    assert report.usage.model_s == pytest.approx(7.0) and report.wall_s > 0
    (end,) = agent.transcript.events("step_end")
    assert (end["answers"], end["prompt_tokens"], end["cached_tokens"], end["model_s"]) == (2, 120, 2400, 7.0)


def test_a_step_out_of_time_ends_and_the_car_keeps_its_specification(loop, server):
    script = [calls(tool_call("set_preferred_steering_direction", {"direction": "left"})),
              Delay(3.0, calls(tool_call("run_left_lane", {"v_ref": 0})))]
    config = AgentConfig(step_budget_s=1.0, backend_attempts=3, retry_backoff_s=0.0)
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver("Pass on the left, then stop on the left.").result(30)
    assert report.ended == "budget" and "time budget of 1 s" in report.errors[-1]
    assert len(llm.requests) == 2  # not retried: the budget was spent waiting
    # the call made in time stands; the late one never came
    assert report.applied_calls == [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "left"}}]
    assert loop.slot.current.get("path_tracking").lane == "center"


def test_a_step_out_of_tokens_asks_for_no_further_answer(loop, server):
    script = [calls(tool_call("set_preferred_steering_direction", {"direction": "left"})),
              calls(tool_call("set_reference_speed", {"v_ref": 10}))]
    config = AgentConfig(step_budget_tokens=100)  # one answer costs 80 (60 read + 20 generated)
    with ScriptedLLM(script, timings=LLAMA_TIMINGS) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver("Left, and slower.").result(30)
    assert report.ended == "budget" and "160" in report.errors[-1] and len(llm.requests) == 2
    assert [c["tool"] for c in report.applied_calls] == ["set_preferred_steering_direction", "set_reference_speed"]


def test_a_call_that_undoes_the_one_just_made_ends_the_step(loop, server, tmp_path):
    script = [calls(tool_call("set_preferred_steering_direction", {"direction": "left"})),
              calls(tool_call("clear_preferred_steering_direction", {})),
              calls(tool_call("set_preferred_steering_direction", {"direction": "left"}))]
    config = AgentConfig(transcript_path=tmp_path / "t.jsonl")
    with ScriptedLLM(script) as llm, Agent(backend(llm), server, config) as agent:
        report = agent.deliver("Pass on the left.").result(30)
    assert report.ended == "undone" and len(llm.requests) == 2
    assert loop.slot.current.get("preferred_steering_direction") is None  # as it was before the step
    assert agent.transcript.events("undone_call")[0]["calls"][0]["tool"] == "clear_preferred_steering_direction"


def _history(steps: int) -> list[Message]:
    history = [Message("system", "S" * 3000, tau=0)]
    for index in range(steps):
        history += [Message("user", f"message {index} " + "u" * 600, tau=len(history)),
                    Message("assistant", "a" * 300, tau=len(history) + 1)]
    return history


def test_the_history_is_cut_at_a_step_and_the_cut_stays_while_it_fits():
    window = ContextWindow(limit_tokens=2000)  # the system message is about 1000 tokens; a step about 310
    assert window.fit(_history(3)) == _history(3)  # fits: all of it
    first = window.fit(_history(4))
    assert first[0].role == "system" and "left out" in first[1].content
    assert first[2].content.startswith("message ") and estimate_tokens(first) <= 2000
    kept_from = first[2].content.split()[1]
    # the next step is appended behind the same cut: the request begins with the same messages (cached)
    second = window.fit(_history(5))
    assert second[:len(first)] == first and second[2].content.split()[1] == kept_from
    assert window.moves == 1
    # a new conversation that fits is sent whole
    assert window.fit(_history(2)) == _history(2)


def test_a_long_dialogue_with_the_model_stays_inside_its_context(loop, server):
    # the full prompt sends the whole history (the compact one says earlier steps in a line each, at most 4)
    with ScriptedLLM() as llm, Agent(backend(llm, context_tokens=2500, max_tokens=200, prompt="full"),
                                     server) as agent:
        for index in range(12):
            agent.deliver(f"Message {index}: tell me something about the road ahead, please. " * 3).result(30)
    sizes = [estimate_tokens([Message(m["role"], m.get("content") or "") for m in r["messages"]])
             for r in llm.requests]
    assert max(sizes) <= 2300 and any("left out" in (m.get("content") or "") for m in llm.requests[-1]["messages"])
    assert llm.requests[-1]["messages"][0]["role"] == "system"


def test_a_paced_run_starts_once_the_model_has_read_its_system_message():
    """Set-up, as loading the model is: a message in the first seconds must not wait for the warm-up."""
    with ScriptedLLM(warmup_s=1.0) as llm:
        setup = AgentSetup(backend(llm), AgentConfig(mode="realtime"))
        with plain_loop(paper_start_config(), agent=setup, pace=1.0) as loop:
            assert not loop.agent.warmed.is_set()
            loop.warm_up()
            assert loop.agent.warmed.is_set() and len(llm.warmups) == 1 and loop.world.time_s == 0.0


def test_reading_a_long_system_message_is_not_cut_at_one_answers_timeout(loop, server, tmp_path):
    """A native-mode system message takes minutes on one thread: the warm-up has its own, longer limit."""
    config = AgentConfig(backend_timeout_s=0.5, warm_up_timeout_s=30.0, transcript_path=tmp_path / "t.jsonl")
    with ScriptedLLM(warmup_s=1.0, timings=LLAMA_TIMINGS) as llm, Agent(backend(llm), server, config) as agent:
        assert agent.warmed.wait(30)
        (warm,) = agent.transcript.events("warm_up")
    assert "error" not in warm and warm["wall_s"] >= 1.0
