"""``agentic-mpc ask "MESSAGE"``: the tool calls the agent makes for one message, without simulating.

A run that never advances: the scenario's world at its start (default: the paper's Scenario 1 in the
plain-Python world, ``scenarios/paper_steering_preference_plain.yaml``: path tracking on the center lane at
15 m/s plus obstacle avoidance, a straight 3-lane left-hand road with a 25 m/s limit), its initial
specification, tools and MCP server; the agent reads the message and calls the tools through the server; the calls the server accepts are printed (``--json``: a JSON list of
``{"tool": name, "arguments": {...}}``). The default backend, ``rules``, is a deterministic rule-based
stand-in, not a language model; ``--backend openai`` asks a real model behind an OpenAI-compatible endpoint,
``--backend llamacpp`` runs a GGUF model file in this process (``pip install "agentic-mpc[llm]"``); see
docs/llm-backends.md::

    agentic-mpc ask "Let's try to avoid obstacles from the right, shall we?" --json
    agentic-mpc ask "An ambulance is coming behind us. We'd better let them pass." \\
        --backend openai --base-url http://localhost:11434/v1 --model granite4:micro --json
    agentic-mpc ask "Please pull over." --backend llamacpp --model-path model.gguf --threads 1

Exit status: 0 when the server accepted at least one tool call; 1 when no call was made (the agent answered
without one, its calls were unreadable or refused, or the backend gave no usable answer: why is printed on
stderr); 2 when the message was rejected (empty or too long) or the backend could not be set up (a missing
or non-GGUF model file, xllamacpp not installed).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from agentic_mpc.commands import add_backend_flags, scenario_file
from agentic_mpc.shipped import scenarios_dir

DEFAULT_SCENARIO = scenarios_dir() / "paper_steering_preference_plain.yaml"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "ask", help="the tool calls the agent makes for a message (no simulation)", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("message", help="what the passenger says")
    add_backend_flags(parser)
    parser.add_argument("--json", action="store_true", help="print only the JSON list of tool calls")
    parser.add_argument("--transcript", type=Path, default=None, help="write the agent's transcript (JSONL) here")
    parser.add_argument("--scenario", type=scenario_file, default=None,
                        help="start from this scenario's world and initial specification (default: the paper's Scenario 1)")
    parser.add_argument("--variant", default=None, help="with --scenario: the variant")
    parser.add_argument("--knowledge", action=argparse.BooleanOptionalAction, default=None,
                        help="the agent has the knowledge server (traffic rules, the car's manual; on by default): a "
                             "question is answered from it, citing the document (docs/knowledge.md)")
    parser.set_defaults(handler=run)


def _settings(args: argparse.Namespace):  # -> AgentSettings
    """The flags as the agent's settings (realtime: nothing advances the sim clock here)."""
    from agentic_mpc.commands import flag_settings, validated_agent_settings

    if args.backend == "llamacpp" and args.model_path is None:
        raise ValueError("--backend llamacpp needs --model-path (a GGUF model file)")
    return validated_agent_settings({**flag_settings(args), "mode": "realtime",
                                     **({} if getattr(args, "knowledge", None) is None else {"knowledge": args.knowledge})})


def _why_no_call(report) -> str:  # report: StepReport
    """Why the agent's step applied no tool call, in one line."""
    if report.ended == "backend_error":
        return "the backend gave no usable answer"
    if report.tool_calls:
        return f"its {len(report.tool_calls)} tool call(s) were unreadable or refused (errors above)"
    if report.text:
        return f"the agent answered without calling a tool: {report.text[:300]!r}"
    return "the agent answered without calling a tool and without text"


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.run.loop import AgentSetup
    from agentic_mpc.scenario.runner import build_loop, build_world
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.scenario.yaml_source import ScenarioFileError
    from agentic_mpc.world.base import WorldError

    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s")
    try:
        scenario = load_scenario(args.scenario or DEFAULT_SCENARIO).variant(args.variant)
    except ScenarioFileError as error:
        print(error, file=sys.stderr)
        return 2
    try:  # before the world starts: a bad model file or a missing package is said at once
        settings = _settings(args)
        backend = None if args.backend == "rules" else settings.build_backend(lefthand=True)
    except (ValueError, ImportError) as error:
        print(f"agentic-mpc ask: the {args.backend} backend could not be set up: {error}", file=sys.stderr)
        return 2
    try:
        world = build_world(scenario)  # a run that never advances: the world at its start
    except WorldError as error:
        print(f"agentic-mpc ask: the scenario's world could not start: {error}", file=sys.stderr)
        return 1
    config = settings.agent_config(transcript_path=args.transcript, backend_attempts=2, retry_backoff_s=0.2)
    backend = backend or settings.build_backend(world.lanes().lefthand)  # rules: the road edge to pull over to
    with build_loop(scenario, world, agent=AgentSetup(backend, config)) as loop:
        report = loop.agent.deliver(args.message).result()
    calls = report.applied_calls
    if args.json:
        print(json.dumps(calls))
    else:
        for call in calls:
            arguments = ", ".join(f"{k}={v!r}" for k, v in call["arguments"].items())
            print(f"{call['tool']}({arguments})")
        if not calls:
            print("(no tool call)")
        if report.text:
            print(f"agent: {report.text}")
    for error in report.errors:
        print(f"error: {error}", file=sys.stderr)
    usage = report.usage
    if usage.model_s is not None:  # a model whose server says what the tokens cost it
        print(f"the step: {usage.answers} answer(s), {usage.prompt_tokens} prompt tokens read ({usage.cached_tokens} "
              f"from the cache), {usage.generated_tokens} generated; the model's time {usage.model_s:.1f} s, the "
              f"step's {report.wall_s:.1f} s (ended: {report.ended})", file=sys.stderr)
    if report.ended == "rejected":
        return 2
    if not calls:
        print(f"no tool call was made: {_why_no_call(report)}", file=sys.stderr)
        return 1
    return 0
