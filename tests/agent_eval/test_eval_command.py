"""``agentic-mpc eval-agent`` in process: the rules backend through the whole shipped suite (real worlds, real
MCP server, real agent), the files it writes, and bad input refused in one line with exit status 2."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from agentic_mpc.agent_eval.suite import load_suite
from agentic_mpc.cli import main


def test_the_rules_backend_runs_the_whole_suite_with_nothing_unparsed(tmp_path, capsys):
    assert main(["eval-agent", "--quiet", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    suite = load_suite()
    assert summary["cases"] == len(suite.cases) and summary["turns"] == sum(len(c.turns) for c in suite.cases)
    assert summary["unparsed_calls"] == 0 and summary["backend_errors"] == 0
    assert set(summary["by_category"]) == set(suite.categories)
    with (tmp_path / "turns.csv").open(encoding="utf-8") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == summary["turns"]
    assert sum(row["verdict"] == "right" for row in rows) == summary["turns_right"]
    assert all(float(row["latency_s"]) >= 0 and row["answer"] for row in rows)  # the rules always say something
    cases = json.loads((tmp_path / "cases.json").read_text(encoding="utf-8"))
    assert sum(case["right"] for case in cases) == summary["cases_right"]
    # the paper's own messages: the rules backend must get these right, on either road
    by_id = {case["id"]: case for case in cases}
    for case_id in ("side-right-paper", "side-left-paper", "yield-L-ambulance-paper", "yield-R-ambulance-paper",
                    "resume-L-paper", "resume-R-paper", "none-nice-day"):
        assert by_id[case_id]["right"], by_id[case_id]
    assert "all" in printed and "latency per turn" in printed
    print(f"rules backend: {summary['cases_right']}/{summary['cases']} cases right ({summary['accuracy']:.0%}), "
          f"by category {({k: v['accuracy'] for k, v in summary['by_category'].items()})}")


def _one_line_error(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    return lines[0]


def test_a_malformed_suite_is_one_line_naming_the_file_and_case(tmp_path, capsys):
    path = tmp_path / "mine.yaml"
    path.write_text("worlds: {w: {scenario: scenarios/plain_world_traffic.yaml}}\ncategories: {c: x}\n"
                    "cases:\n  - {id: broken-one, category: c, world: w, message: hi, expect: [{args: {}}]}\n",
                    encoding="utf-8")
    assert main(["eval-agent", "--suite", str(path)]) == 2
    line = _one_line_error(capsys)
    assert str(path) in line and "case 'broken-one'" in line and "'tool'" in line


def test_a_missing_model_file_is_one_line(tmp_path, capsys):
    missing = tmp_path / "nothing.gguf"
    assert main(["eval-agent", "--backend", "llamacpp", "--model-path", str(missing)]) == 2
    line = _one_line_error(capsys)
    assert "could not be set up" in line and str(missing) in line


@pytest.mark.parametrize("argv, complaint", [
    (["--model-path", "x.gguf"], "--model-path applies to --backend llamacpp, not rules"),
    (["--backend", "openai", "--threads", "2"], "--threads applies to --backend llamacpp, not openai"),
    (["--backend", "llamacpp"], "needs --model-path"),
    (["--closed-loop", "--category", "yield"], "--closed-loop runs the paper's scenarios"),
    (["--category", "jokes"], "no category 'jokes'"),
    (["--backend", "openai", "--extra-body", "{nope"], "--extra-body is not JSON"),
])
def test_options_that_do_not_apply_are_one_line(capsys, argv, complaint):
    assert main(["eval-agent", *argv]) == 2
    assert complaint in _one_line_error(capsys)


def test_closed_loop_settings_reach_the_scenarios_agent():
    from agentic_mpc.agent_eval.closed_loop import SCENARIO_1
    from agentic_mpc.cli import build_parser
    from agentic_mpc.commands import with_agent_settings
    from agentic_mpc.commands.eval_agent import _agent_settings
    from agentic_mpc.scenario.schema import load_scenario

    scenario = load_scenario(SCENARIO_1).variant(None)
    parser = build_parser()
    for argv, rounds in ((["--max-rounds", "1"], 1), ([], scenario.agent.max_rounds_per_step)):
        args = parser.parse_args(["eval-agent", "--closed-loop", *argv])
        assert with_agent_settings(scenario, _agent_settings(args)).agent.max_rounds_per_step == rounds
    args = parser.parse_args(["eval-agent", "--closed-loop", "--backend", "openai", "--model", "qwen",
                              "--tool-mode", "native", "--max-rounds", "1", "--max-tokens", "160"])
    agent = with_agent_settings(scenario, _agent_settings(args)).agent
    assert (agent.backend, agent.model, agent.tool_mode, agent.max_rounds_per_step, agent.max_tokens) == (
        "openai", "qwen", "native", 1, 160)


def test_an_unknown_backend_is_refused_by_argparse(capsys):
    with pytest.raises(SystemExit) as exited:
        main(["eval-agent", "--backend", "gpt"])
    assert exited.value.code == 2 and "invalid choice: 'gpt'" in capsys.readouterr().err


def test_the_suite_file_ships_with_the_package():
    import agentic_mpc.agent_eval as package

    assert (Path(package.__file__).parent / "suite.yaml").is_file()


def test_the_openai_backend_and_rules_first_routing_against_an_http_endpoint(tmp_path, capsys):
    """A real OpenAI-compatible HTTP server on 127.0.0.1 answering from a script: with ``--rules-first`` only
    the messages the rules do not understand reach it; its tool calls are scored like any backend's."""
    from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call

    script = [text("It is, isn't it?"),  # "What a nice day!": a reply, no call (right)
              calls(tool_call("set_preferred_steering_direction", {"direction": "left"}))]  # German "rechts": wrong
    argv = ["eval-agent", "--backend", "openai", "--model", "scripted", "--rules-first", "--quiet",
            "--case", "side-right-paper", "--case", "none-nice-day", "--case", "de-right", "--out", str(tmp_path)]
    with ScriptedLLM(script) as llm:
        assert main([*argv, "--base-url", llm.base_url]) == 0
    asked = [request["messages"][-1]["content"] for request in llm.requests]
    assert len(asked) == 2 and "What a nice day!" in asked[0] and "Hindernissen" in asked[1]  # its reply: templated
    cases = {case["id"]: case for case in json.loads((tmp_path / "cases.json").read_text(encoding="utf-8"))}
    assert cases["side-right-paper"]["right"] and cases["none-nice-day"]["right"]  # rules, then the endpoint
    wrong = cases["de-right"]["turns"][0]
    assert not cases["de-right"]["right"] and wrong["calls"] == [
        {"tool": "set_preferred_steering_direction", "arguments": {"direction": "left"}}]
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert summary["backend"] == "rules+openai" and summary["cases_right"] == 2
