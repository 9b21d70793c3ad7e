"""The whole control step in the incident scenario (controller, surroundings, SUMO, agent): this tree against
another commit, in one run.

    .venv/bin/python benchmarks/bench_incident_step.py [--base REV] [--variant ambulance_left] [--seed 900]
        [--rounds 3] [--from-s 95] [--to-s 125]

Runs ``incident_in_traffic`` from each tree in turn, in fresh processes (BLAS and Numba on one thread), and times
every ``RunLoop.step`` between ``--from-s`` and ``--to-s`` (the ego enters at 90 s and reaches the first stopped
car's queue in this window, where the queue room, the detour and the drivers' release run). The two trees drive
the same seed but not always the same path once their behaviour differs, so the ratio is of the same scene, not of
identical steps. Prints each round's medians and the ratio new / old. Idle machine.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

from worktree import REPO, checkout, environment

CHILD = r"""
import json, sys, time
import numpy as np
from agentic_mpc.scenario.runner import build_loop, build_world
from agentic_mpc.scenario.schema import load_scenario

variant, seed, start_s, end_s = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
scenario = load_scenario("scenarios/incident_in_traffic.yaml").variant(variant).with_seed(seed)
scenario = scenario.model_copy(update={"outputs": scenario.outputs.model_copy(update={"replay": False})})
world = build_world(scenario)
loop = build_loop(scenario, world)
times = []
try:
    while world.time_s < end_s:
        t0 = time.perf_counter()
        loop.step()
        if world.time_s > start_s:
            times.append(time.perf_counter() - t0)
finally:
    loop.close()
print(json.dumps({"median_ms": 1e3 * float(np.median(times)), "p90_ms": 1e3 * float(np.percentile(times, 90))}))
"""


def run(tree, args) -> dict:
    command = [sys.executable, "-c", CHILD, args.variant, str(args.seed), str(args.from_s), str(args.to_s)]
    out = subprocess.run(command, check=True, capture_output=True, text=True, env=environment(tree), cwd=tree).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="e1d181f")
    parser.add_argument("--variant", default="ambulance_left")
    parser.add_argument("--seed", type=int, default=900)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--from-s", type=float, default=95.0)
    parser.add_argument("--to-s", type=float, default=125.0)
    args = parser.parse_args()
    new, old = [], []
    with checkout(args.base) as old_tree:
        for round_ in range(args.rounds):
            new.append(run(REPO, args))
            old.append(run(old_tree, args))
            print(f"round {round_ + 1}: new {new[-1]['median_ms']:.3f} ms (p90 {new[-1]['p90_ms']:.3f}), "
                  f"old {old[-1]['median_ms']:.3f} ms (p90 {old[-1]['p90_ms']:.3f})")
    n = statistics.median(r["median_ms"] for r in new)
    o = statistics.median(r["median_ms"] for r in old)
    print(f"{args.variant} seed {args.seed}, steps {args.from_s:g}-{args.to_s:g} s: new {n:.3f} ms, "
          f"{args.base} {o:.3f} ms, ratio new/old {n / o:.2f}")


if __name__ == "__main__":
    main()
