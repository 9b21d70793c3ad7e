"""``agentic-mpc ask "MESSAGE"``: the tool calls the agent makes for one message, without simulating.

The agent starts from the paper's initial specification (path tracking on the center lane at 15 m/s plus
obstacle avoidance, on a straight 3-lane road with a 25 m/s limit), reads the message and calls the tools
through the in-process MCP server; the calls the server accepts are printed (``--json``: a JSON list of
``{"tool": name, "arguments": {...}}``). The default backend, ``rules``, is a deterministic rule-based
stand-in, not a language model; ``--backend openai`` asks a real model behind an OpenAI-compatible endpoint::

    agentic-mpc ask "Let's try to avoid obstacles from the right, shall we?" --json
    agentic-mpc ask "An ambulance is coming behind us. We'd better let them pass." \\
        --backend openai --base-url http://localhost:11434/v1 --model granite4:micro --json

Exit status: 0 when the agent answered (with or without tool calls), 1 when the backend gave no usable
answer, 2 when the message was rejected (empty or too long).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "ask", help="the tool calls the agent makes for a message (no simulation)", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("message", help="what the passenger says")
    parser.add_argument("--backend", choices=("rules", "openai"), default="rules",
                        help="rules: offline rule-based stand-in (default); openai: an OpenAI-compatible LLM endpoint")
    parser.add_argument("--base-url", default=None, help="openai: the endpoint's /v1 URL (default Ollama's)")
    parser.add_argument("--model", default=None, help="openai: model name (default granite4:micro)")
    parser.add_argument("--api-key-env", default="OPENAI_API_KEY", help="openai: environment variable with the API key")
    parser.add_argument("--timeout-s", type=float, default=120.0, help="openai: seconds per request")
    parser.add_argument("--yield-lane", choices=("left", "right"), default=None,
                        help="rules: where to pull over for emergency vehicles (default: the road edge side; "
                             "left in the paper's left-hand traffic)")
    parser.add_argument("--json", action="store_true", help="print only the JSON list of tool calls")
    parser.add_argument("--transcript", type=Path, default=None, help="write the agent's transcript (JSONL) here")
    parser.add_argument("--scenario", type=Path, default=None,
                        help="start from this scenario's initial specification and road (default: the paper's)")
    parser.add_argument("--variant", default=None, help="with --scenario: the variant")
    parser.set_defaults(handler=run)


def _backend(args: argparse.Namespace):  # -> Backend
    from agentic_mpc.agent.backends import make_backend

    if args.backend == "rules":
        return make_backend("rules", yield_lane=args.yield_lane or "left")
    options = {"api_key_env": args.api_key_env or None, "timeout_s": args.timeout_s}
    if args.base_url:
        options["base_url"] = args.base_url
    if args.model:
        options["model"] = args.model
    return make_backend("openai", **options)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.agent import Agent, AgentConfig
    from agentic_mpc.mcp_server import build_server
    from agentic_mpc.plain_world import StraightRoad, paper_initial_specification
    from agentic_mpc.primitives import Circle, SpecificationSlot
    from agentic_mpc.tools import ControllerTools

    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s")
    road = StraightRoad()
    lanes, speed_limit_mps = road.lanes(), road.speed_limit_mps
    obstacle = Circle(x_m=45.0, y_m=0.0, radius_m=2.0, label="obstacle0")
    initial = paper_initial_specification(lanes, v_ref_mps=15.0, obstacles=[obstacle])
    if args.scenario is not None:
        from agentic_mpc.scenario.runner import dry_specification
        from agentic_mpc.scenario.schema import load_scenario
        from agentic_mpc.scenario.yaml_source import ScenarioFileError

        try:
            scenario = load_scenario(args.scenario).variant(args.variant)
        except ScenarioFileError as error:
            print(error, file=sys.stderr)
            return 2
        initial, (lanes, speed_limit_mps), lefthand = dry_specification(scenario)
        if args.yield_lane is None:
            args.yield_lane = "left" if lefthand else "right"
    slot = SpecificationSlot(initial)
    tools = ControllerTools(slot, lambda: (lanes, speed_limit_mps))
    observation = {
        "time_s": 0.0,
        "ego": {"id": "ego", "x_m": 0.0, "y_m": 0.0, "heading_rad": 0.0, "speed_mps": 15.0, "lane": "center"},
        "traffic": [],
        "emergency_vehicles": [],
        "obstacles": [{"id": obstacle.label, "x_m": obstacle.x_m, "y_m": obstacle.y_m, "radius_m": obstacle.radius_m}],
        "collisions": [],
    }
    server = build_server(tools, lambda: observation)
    config = AgentConfig(transcript_path=args.transcript, backend_attempts=2, retry_backoff_s=0.2,
                         backend_timeout_s=args.timeout_s + 5.0)
    with Agent(_backend(args), server, config) as agent:
        report = agent.deliver(args.message).result()
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
    if report.ended == "rejected":
        return 2
    if report.ended == "backend_error":
        return 1
    return 0
