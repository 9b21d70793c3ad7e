"""``agentic-mpc run FILE [--variant V] [--seed N] [--out DIR]``: run one scenario in SUMO.

Writes ``trajectory.csv``, ``events.csv``, ``traffic.csv``, ``summary.csv``, ``transcript.jsonl``,
``scenario.json`` and ``trajectory.png`` to DIR and prints a short summary.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agentic_mpc.commands import CommandInputError, agent_setting, non_negative_int, scenario_file, scenario_for


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("run", help="run one scenario", description=__doc__)
    parser.add_argument("file", type=scenario_file, metavar="FILE", help="scenario YAML, or a shipped scenario's name")
    parser.add_argument("--variant", default=None, help="variant name (default: the base scenario)")
    parser.add_argument("--seed", type=non_negative_int, default=None, help="seed (default: the scenario's)")
    parser.add_argument("--out", type=Path, default=None, help="output directory (default: out/<scenario>/<variant>/seed-<N>)")
    parser.add_argument("--agent", type=agent_setting, action="append", default=[], metavar="KEY=VALUE",
                        help="override a setting of the scenario's agent (repeatable), e.g. --agent backend=llamacpp "
                             "--agent model=PATH.gguf --agent temperature=0.2 (see docs/llm-backends.md)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.scenario.runner import run_scenario

    try:
        scenario = scenario_for("run", args.file, args.variant, args.seed, args.agent)
    except CommandInputError as error:
        print(error, file=sys.stderr)
        return 2
    out = args.out or Path("out") / scenario.name / scenario.variant / f"seed-{scenario.seed}"
    try:
        summary = run_scenario(scenario, out)
    except Exception as error:  # the runner has written what it recorded
        print(f"agentic-mpc run: {scenario.name}/{scenario.variant} seed {scenario.seed} failed: {error}", file=sys.stderr)
        print(f"what was recorded is in {out}", file=sys.stderr)
        return 1
    keys = ("collisions", "reached_goal", "obstacle_side", "min_obstacle_clearance_m", "min_gap_m", "lane_rms_error_m",
            "mean_speed_mps", "ambulance_delay_s", "agent_tool_calls", "controller_ms_median", "wall_s")
    print(f"{scenario.name} / {scenario.variant} / seed {scenario.seed}: {summary['steps']} steps, {summary['sim_time_s']} s")
    for key in keys:
        print(f"  {key:26s} {summary[key]}")
    print(f"wrote {out}")
    return 0
