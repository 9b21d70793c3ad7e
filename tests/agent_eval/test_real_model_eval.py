"""The suite with a real language model: SmolLM2-135M-Instruct (GGUF, fetched by ``make test``,
tests/agent/fetch_model.py) in process through ``llamacpp``, json_schema mode, one thread, on the first case of
six categories (``SAMPLE``). Every answer must be read: a call of a listed tool or a reply, nothing
unparsed. Its accuracy is printed, not asserted (a 135M model gets few right). Skipped without the model
file or xllamacpp."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from agentic_mpc.agent_eval.report import summarise
from agentic_mpc.agent_eval.runner import KeepOpen, run_suite, suite_agent_config
from agentic_mpc.agent_eval.suite import load_suite

REPO = Path(__file__).resolve().parents[2]
MODEL = Path(os.environ.get("AGENTIC_MPC_TEST_GGUF") or REPO / ".cache/models/SmolLM2-135M-Instruct.Q4_1.gguf")

pytest.importorskip("xllamacpp", reason='xllamacpp is not installed: pip install -e ".[llm]"')
pytestmark = [
    pytest.mark.slow,  # about a minute on one thread of a shared 2-core machine
    pytest.mark.skipif(not MODEL.is_file(), reason=f"no model file at {MODEL}: `make test` fetches it "
                       "(tests/agent/fetch_model.py), or set AGENTIC_MPC_TEST_GGUF"),
]


SAMPLE = ["speed_unit", "yield", "no_call", "non_english"]
"""One case of each of these categories: numbers with units, a lane call, a reply, another language (the
issue's 5 messages are answered in tests/agent/test_real_model.py too)."""


def test_smollm2_answers_a_sample_of_the_suite_with_nothing_unparsed():
    from agentic_mpc.agent.backends.llamacpp import LlamaCppBackend
    from agentic_mpc.agent.settings import LlamaCppSettings

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    suite = load_suite()
    cases = suite.select(categories=SAMPLE, per_category=1)  # the whole suite is eval-agent's job (minutes)
    model = LlamaCppBackend(LlamaCppSettings(model=MODEL, threads=1, ctx_size=4096, max_tokens=128,
                                           tool_mode="json_schema"))
    try:  # one answer per turn: what is judged here is whether the answer is read, not what follows it
        results = run_suite(suite, cases, lambda lefthand: KeepOpen(model), suite_agent_config(LlamaCppSettings(model=MODEL, max_rounds_per_step=1)))
    finally:
        model.close()
    turns = [turn for result in results for turn in result.turns]
    assert len(results) == len(SAMPLE) and len(turns) == sum(len(c.turns) for c in cases)
    for turn in turns:
        where = f"{turn.case_id} turn {turn.turn} ({turn.message!r})"
        assert turn.ended in ("idle", "round_limit"), f"{where}: {turn.ended} {turn.errors}"
        assert not turn.unparsed, f"{where}: unparsed {turn.unparsed}"
        # llama.cpp's grammar bounds integers, not numbers: a v_ref above the limit is one allowed refusal; the
        # other is the controller's, with its reason (a following distance with no car ahead)
        assert all("maximum" in why or "minimum" in why or "outside [0" in why or "Error executing tool" in why
                   for why in turn.invalid), where
        assert turn.calls or turn.invalid or turn.answer.strip(), f"{where}: neither a call nor a reply"
    summary = summarise(results, suite.categories, {"backend": "llamacpp", "model": MODEL.name})
    print(f"SmolLM2-135M on {len(cases)} cases: {summary['cases_right']} right; latency p50 "
          f"{summary['latency_p50_s']} s, p95 {summary['latency_p95_s']} s")
