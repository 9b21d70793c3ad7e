"""``agentic-mpc bench``: time one controller step (sampling, rollouts, costs, weighting)."""

from __future__ import annotations

import argparse
import json
import time

from agentic_mpc.commands import positive_int


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("bench", help="time the Fourier MPPI step", description=__doc__)
    parser.add_argument("--horizon", type=positive_int, default=50, help="prediction horizon H (steps)")
    parser.add_argument("--samples", type=positive_int, default=256, help="samples S")
    parser.add_argument("--steps", type=positive_int, default=500, help="timed controller steps")
    parser.add_argument("--backend", choices=("fast", "reference"), default="fast")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    from agentic_mpc.benchmark import benchmark_controller_step

    imported_s = time.perf_counter() - started
    result = benchmark_controller_step(args.horizon, args.samples, args.steps, args.backend, args.seed)
    result["import_s"] = round(imported_s, 4)
    result["startup_s"] = round(imported_s + result["first_step_s"], 4)
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"H={args.horizon} S={args.samples} {args.backend}: median {result['median_ms']:.3f} ms "
            f"(p10 {result['p10_ms']:.3f}, p90 {result['p90_ms']:.3f}), {result['realtime_factor']:.0f}x real time, "
            f"start-up {result['startup_s']:.2f} s"
        )
    return 0
