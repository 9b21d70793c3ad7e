"""The ``llamacpp`` backend's set-up: the model file is checked before anything runs, with a clear error;
the backend is registered where backends are chosen (``make_backend``, the scenario's ``agent.backend``)."""

from __future__ import annotations

import pytest

from agentic_mpc.agent.backends import BACKENDS, make_backend
from agentic_mpc.agent.backends.llamacpp import ModelFileError, check_gguf
from agentic_mpc.agent.settings import LlamaCppSettings, agent_settings


def test_a_missing_model_file_is_a_clear_error(tmp_path):
    with pytest.raises(ModelFileError, match="does not exist"):
        make_backend("llamacpp", model=tmp_path / "nothing.gguf")


def test_a_file_that_is_not_gguf_is_a_clear_error(tmp_path):
    path = tmp_path / "model.gguf"
    path.write_text("<html>a download error page</html>")
    with pytest.raises(ModelFileError, match=r"is not a GGUF model file \(it starts with b'<htm'"):
        make_backend("llamacpp", model=path)
    with pytest.raises(ModelFileError, match="is not a file"):
        check_gguf(tmp_path)
    assert isinstance(ModelFileError("x"), ValueError)


def test_a_gguf_file_that_llama_cpp_cannot_load_is_a_clear_error(tmp_path):
    pytest.importorskip("xllamacpp", reason='xllamacpp is not installed: pip install -e ".[llm]"')
    path = tmp_path / "truncated.gguf"
    path.write_bytes(b"GGUF" + bytes(60))
    with pytest.raises(ModelFileError, match="llama.cpp could not load"):
        make_backend("llamacpp", model=path)


def test_defaults_suit_a_small_shared_machine(tmp_path):
    (tmp_path / "m.gguf").write_bytes(b"GGUF" + bytes(60))
    config = LlamaCppSettings(model=tmp_path / "m.gguf")
    assert (config.threads, config.effective_tool_mode, config.temperature) == (1, "json_schema", 0.0)
    assert "llamacpp" in BACKENDS


def test_a_scenario_can_choose_it(tmp_path):
    # the file is checked when the scenario is read, before any world starts
    with pytest.raises(ValueError, match="granite.gguf does not exist"):
        agent_settings(backend="llamacpp", model=str(tmp_path / "granite.gguf"))
    fake = tmp_path / "fake.gguf"
    fake.write_bytes(b"GGUF" + bytes(60))  # passes the check, but llama.cpp cannot load it: said when built
    settings = agent_settings(backend="llamacpp", model=str(fake), threads=2, ctx_size=1024)
    with pytest.raises(ModelFileError, match="llama.cpp could not load"):
        settings.build_backend(lefthand=True)
    # a small model in process gets the rules in front of it unless told otherwise (docs/llm-backends.md)
    model_alone = agent_settings(backend="llamacpp", model=str(fake), rules_first=False)
    assert settings.rules_first and not model_alone.rules_first
    assert not agent_settings(backend="openai").rules_first  # an endpoint may serve a strong model
    # the history is kept inside the context, less one answer
    assert settings.context_limit_tokens == 1024 - settings.max_tokens


def test_a_streamed_answer_is_assembled_into_one_message():
    from agentic_mpc.agent.backends.base import BackendError
    from agentic_mpc.agent.backends.llamacpp import assemble_stream

    def chunk(delta, finish=None):
        return {"choices": [{"index": 0, "delta": delta, "finish_reason": finish}]}

    chunks = [chunk({"role": "assistant", "content": None}), chunk({"content": "Pulling "}), chunk({"content": "over."}),
              chunk({"tool_calls": [{"index": 0, "id": "c1", "type": "function",
                                     "function": {"name": "run_left_lane", "arguments": '{"v_r'}}]}),
              chunk({"tool_calls": [{"index": 0, "function": {"arguments": 'ef": 0}'}}]}), chunk({}, "tool_calls")]
    (choice,) = assemble_stream(chunks)["choices"]
    assert choice["finish_reason"] == "tool_calls"
    assert choice["message"] == {"role": "assistant", "content": "Pulling over.", "tool_calls": [
        {"id": "c1", "type": "function", "function": {"name": "run_left_lane", "arguments": '{"v_ref": 0}'}}]}
    with pytest.raises(BackendError, match="exceeds the available context size"):
        assemble_stream([{"error": {"code": 400, "message": "request (431 tokens) exceeds the available context size"}}])
    with pytest.raises(BackendError, match="no answer"):
        assemble_stream([])
