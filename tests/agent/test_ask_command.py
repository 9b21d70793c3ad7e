"""``agentic-mpc ask``: the calls the agent makes from the paper's initial specification, as JSON."""

from __future__ import annotations

import argparse
import json
import socket

import pytest

from agentic_mpc.commands import ask
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call


def ask_main(*argv: str) -> int:
    parser = argparse.ArgumentParser(prog="agentic-mpc")
    ask.register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["ask", *argv])
    return args.handler(args)


@pytest.mark.parametrize(
    ("message", "expected"),
    [
        ("Let's try to avoid obstacles from the right, shall we?",
         [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "right"}}]),
        ("Let's try to avoid obstacles from the left, shall we?",
         [{"tool": "set_preferred_steering_direction", "arguments": {"direction": "left"}}]),
        ("An ambulance is coming behind us. We'd better let them pass.",
         [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]),
        ("Thank you. The ambulance is gone.", [{"tool": "run_center_lane", "arguments": {"v_ref": 15}}]),
        ("slow down to 36 km/h", [{"tool": "set_reference_speed", "arguments": {"v_ref": 10}}]),
        ("What a nice day!", []),
    ],
)
def test_ask_prints_the_paper_calls_as_json(capsys, message, expected):
    assert ask_main(message, "--json") == (0 if expected else 1)  # 1: no tool call was made
    assert json.loads(capsys.readouterr().out) == expected


def test_ask_human_readable(capsys):
    assert ask_main("Don't pass on the left") == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "set_preferred_steering_direction(direction='right')"
    assert "agent: " in out


def test_ask_with_the_openai_backend(capsys, tmp_path):
    script = [calls(tool_call("run_left_lane", {"v_ref": 0})), text("Made way.")]
    with ScriptedLLM(script) as llm:
        code = ask_main("An ambulance is coming behind us.", "--backend", "openai", "--base-url", llm.base_url,
                        "--model", "granite4:micro", "--json", "--transcript", str(tmp_path / "t.jsonl"))
    assert code == 0
    assert json.loads(capsys.readouterr().out) == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert llm.requests[0]["model"] == "granite4:micro"
    assert (tmp_path / "t.jsonl").read_text().count('"event": "tool_call"') == 1


def test_ask_with_an_unreachable_backend_fails_clearly(capsys):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code = ask_main("hello", "--backend", "openai", "--base-url", f"http://127.0.0.1:{port}/v1", "--timeout-s", "2",
                    "--json")
    captured = capsys.readouterr()
    assert code == 1 and json.loads(captured.out) == []
    assert "cannot reach" in captured.err


def test_ask_rejects_an_empty_message(capsys):
    assert ask_main("  ", "--json") == 2
    assert "empty message" in capsys.readouterr().err


def test_ask_names_a_missing_scenario_file(capsys, tmp_path):
    assert ask_main("go 10 m/s", "--json", "--scenario", str(tmp_path / "scenario.yaml")) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and f"{tmp_path / 'scenario.yaml'}: cannot read" in captured.err


def test_ask_starts_from_a_scenario_and_yields_to_its_road_edge():
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    message = "An ambulance is coming behind us. We'd better let them pass."

    def ask(scenario: str) -> list:
        result = subprocess.run(
            [sys.executable, "-m", "agentic_mpc", "ask", message, "--scenario", str(repo / "scenarios" / scenario), "--json"],
            capture_output=True, text=True, timeout=120,
        )
        assert result.returncode == 0, result.stderr
        return json.loads(result.stdout)

    # left-hand traffic (the paper's): pull over to the left; right-hand traffic: to the right
    assert ask("paper_emergency_response.yaml") == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    assert ask("paper_steering_preference.yaml") == [{"tool": "run_right_lane", "arguments": {"v_ref": 0}}]


def test_ask_says_why_no_call_was_made_when_the_model_answers_in_prose(capsys):
    with ScriptedLLM([text("Pulling over now, the ambulance can pass.")]) as llm:
        code = ask_main("An ambulance is coming behind us.", "--backend", "openai", "--base-url", llm.base_url)
    captured = capsys.readouterr()
    assert code == 1 and "(no tool call)" in captured.out
    assert ("no tool call was made: the agent answered without calling a tool: "
            "'Pulling over now, the ambulance can pass.'") in captured.err


def test_ask_says_why_no_call_was_made_when_the_call_is_unreadable(capsys):
    broken = text('```json\n{"name": "run_left_lane", "arguments": {"v_ref": 0\n```')
    with ScriptedLLM([broken] * 3) as llm:
        code = ask_main("An ambulance is coming behind us.", "--backend", "openai", "--base-url", llm.base_url,
                        "--json")
    captured = capsys.readouterr()
    assert code == 1 and json.loads(captured.out) == []
    assert "could not read the tool call" in captured.err
    assert "no tool call was made: its 3 tool call(s) were unreadable or refused" in captured.err


def test_ask_passes_the_model_options(capsys):
    script = [text('{"name": "run_left_lane", "arguments": {"v_ref": 0}}'), text('{"reply": "Done."}')]
    with ScriptedLLM(script) as llm:
        code = ask_main("An ambulance is coming behind us.", "--backend", "openai", "--base-url", llm.base_url,
                        "--tool-mode", "json_schema", "--temperature", "0.3", "--max-tokens", "64", "--json")
    assert code == 0 and json.loads(capsys.readouterr().out) == [{"tool": "run_left_lane", "arguments": {"v_ref": 0}}]
    first = llm.requests[0]
    assert first["response_format"]["type"] == "json_schema" and "tools" not in first
    assert first["temperature"] == 0.3 and first["max_tokens"] == 64


@pytest.mark.parametrize(("content", "why"), [(None, "does not exist"), (b"PK\x03\x04 a zip", "is not a GGUF model file")])
def test_ask_with_a_bad_model_file_fails_before_the_run(capsys, tmp_path, content, why):
    path = tmp_path / "model.gguf"
    if content is not None:
        path.write_bytes(content)
    assert ask_main("hello", "--backend", "llamacpp", "--model-path", str(path)) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and why in captured.err and str(path) in captured.err


def test_a_question_is_answered_from_the_document_it_cites_knowledge_being_on_by_default(capsys):
    from agentic_mpc.cli import main

    assert main(["ask", "What is the speed limit on a Japanese expressway?"]) == 0
    out = capsys.readouterr().out
    assert "knowledge__search_knowledge(query='What is the speed limit on a Japanese expressway?'" in out
    assert "jp-traffic-rules" in out and "100 km/h" in out


def test_without_knowledge_nothing_is_searched(capsys):
    from agentic_mpc.cli import main

    main(["ask", "What is the speed limit on a Japanese expressway?", "--no-knowledge"])
    out = capsys.readouterr().out
    assert "knowledge__search_knowledge" not in out and "jp-traffic-rules" not in out
