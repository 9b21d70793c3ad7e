"""A scenario's ``agent:`` settings: every backend option in the file and as ``--agent KEY=VALUE``, validated
with the key named, a missing or non-GGUF model file refused before anything starts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from agentic_mpc.commands import with_agent_settings
from agentic_mpc.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[2]
PLAIN = REPO / "scenarios/paper_steering_preference_plain.yaml"


def test_overrides_are_read_as_yaml_and_validated_like_the_file():
    scenario = with_agent_settings(load_scenario(PLAIN).variant("message_left"), [
        ("backend", "openai"), ("model", "1.5"), ("temperature", "0.3"), ("max_tokens", "96"),
        ("tool_mode", "json_schema"), ("extra_body", "{top_p: 0.9}"), ("extra_prompt", "Be brief."),
        ("mode", "realtime")])
    agent = scenario.agent
    assert (agent.model, agent.temperature, agent.max_tokens, agent.tool_mode) == ("1.5", 0.3, 96, "json_schema")
    assert agent.extra_body == {"top_p": 0.9} and agent.extra_prompt == "Be brief." and agent.mode == "realtime"
    backend = agent.build_backend(lefthand=True)  # the options reach the backend's own config
    assert (backend.config.temperature, backend.config.max_tokens, backend.config.extra_body) == (0.3, 96, {"top_p": 0.9})


@pytest.mark.parametrize("pair, said", [
    (("colour", "blue"), "--agent colour: not an agent setting"),
    (("max_rounds_per_step", "many"), "--agent max_rounds_per_step: Input should be a valid integer"),
    (("temperature", "0.2"), "--agent temperature: not an agent setting of the rules backend"),
    (("max_tokens", "0"), "--agent max_tokens:"),
])
def test_a_bad_override_names_its_key(pair, said):
    with pytest.raises(ValueError, match=said):
        with_agent_settings(load_scenario(PLAIN).variant(None), [pair])


def test_a_missing_model_file_is_refused_before_the_run_starts(tmp_path):
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "agentic_mpc", "run", str(PLAIN), "--out", str(out), "--agent",
                           "backend=llamacpp", "--agent", f"model={tmp_path / 'none.gguf'}"],
                          capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 2 and "--agent model:" in done.stderr and "does not exist" in done.stderr
    assert "Traceback" not in done.stderr and not out.exists()  # nothing started


def test_check_names_the_yaml_path_of_a_file_that_is_not_gguf(tmp_path):
    scenario = tmp_path / "s.yaml"
    text = PLAIN.read_text().replace("  backend: rules\n", f"  backend: llamacpp\n  model: {PLAIN}\n", 1)
    scenario.write_text(text)
    done = subprocess.run([sys.executable, "-m", "agentic_mpc", "check", str(scenario)], capture_output=True,
                          text=True, cwd=REPO, timeout=60)
    assert done.returncode == 2 and "agent.model: " in done.stdout + done.stderr
    assert "is not a GGUF model file" in done.stdout + done.stderr
