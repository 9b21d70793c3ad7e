"""The controller step of this working tree against another commit's, measured in one run on one machine.

    .venv/bin/python benchmarks/bench_versus_commit.py [--base REV] [--rounds 7] [--horizon 50 --samples 256]

Checks ``REV`` (default ``HEAD``, so the uncommitted change is what is measured) out into a temporary git
worktree and runs ``agentic-mpc bench --json`` from each tree in turn, alternating, in fresh processes with
BLAS and Numba on one thread, so that both see the same machine and the same load. Prints each round and the
median of the per-round medians with the ratio new / old. Run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from worktree import REPO, checkout, environment


def bench(tree: Path, args: argparse.Namespace) -> dict:
    env = environment(tree)
    command = [sys.executable, "-m", "agentic_mpc", "bench", "--json", "--horizon", str(args.horizon),
               "--samples", str(args.samples), "--steps", str(args.steps), "--backend", args.backend]
    return json.loads(subprocess.run(command, check=True, capture_output=True, text=True, env=env, cwd=tree).stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--base", default="HEAD", help="the commit to compare against (default HEAD)")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--horizon", type=int, default=50)
    parser.add_argument("--samples", type=int, default=256)
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--backend", default="fast", choices=("fast", "reference"))
    args = parser.parse_args()
    with checkout(args.base) as old:
        trees = {"old": old, "new": REPO}
        for tree in trees.values():
            bench(tree, args)  # compile and fill each tree's Numba cache outside the timed rounds
        medians: dict[str, list[float]] = {name: [] for name in trees}
        for round_ in range(args.rounds):
            for name, tree in trees.items():
                medians[name].append(bench(tree, args)["median_ms"])
            print(json.dumps({"round": round_, **{f"{name}_median_ms": m[-1] for name, m in medians.items()}}))
        old_ms, new_ms = statistics.median(medians["old"]), statistics.median(medians["new"])
        print(json.dumps({"base": args.base, "horizon": args.horizon, "samples": args.samples,
                          "backend": args.backend, "old_median_ms": old_ms, "new_median_ms": new_ms,
                          "ratio_new_over_old": round(new_ms / old_ms, 3)}))


if __name__ == "__main__":
    main()
