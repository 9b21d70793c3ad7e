"""Whole-process wall times a user waits for: ``agentic-mpc check`` of a scenario file and ``agentic-mpc run``
of the paper's Scenario 1 (``message_right``, 300 steps), median of N runs each (default 5).

    .venv/bin/python benchmarks/bench_startup.py [--repeat 5] [--base REV]

With ``--base REV`` the same commands also run from ``REV`` checked out beside this tree (a git worktree),
alternating, so old and new are measured in one run on the same machine; each line then has both medians
and their ratio. Prints one JSON line per command. Run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import nullcontext
from pathlib import Path

from worktree import REPO, checkout, environment

NO_FIGURE = ("import sys; from agentic_mpc.scenario.schema import load_scenario; "
             "from agentic_mpc.scenario.runner import run_scenario; "
             "s = load_scenario(sys.argv[1]).variant('message_right'); "
             "run_scenario(s.model_copy(update={'outputs': s.outputs.model_copy(update={'plot': False})}), sys.argv[2])")


def commands(tree: Path, out: str) -> dict[str, list[str]]:
    cli = [sys.executable, "-m", "agentic_mpc"]
    s1 = str(tree / "scenarios" / "paper_steering_preference.yaml")
    return {
        "check": [*cli, "check", s1],
        "run scenario 1 message_right": [*cli, "run", s1, "--variant", "message_right", "--out", out],
        "run scenario 1 message_right, no figure": [sys.executable, "-c", NO_FIGURE, s1, out],
        "python -c pass (the interpreter alone)": [sys.executable, "-c", "pass"],
    }


def wall_time(command: list[str], tree: Path) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tree,
                   env=environment(tree))
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--base", default=None, help="also time this commit, side by side (e.g. HEAD~3)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as out, (checkout(args.base) if args.base else nullcontext(None)) as old:
        trees = {"new": REPO, **({"old": old} if old is not None else {})}
        for tree in trees.values():  # warm the Numba caches and the OS's file cache outside the timings
            wall_time(commands(tree, out)["run scenario 1 message_right, no figure"], tree)
        for name in commands(REPO, out):
            times: dict[str, list[float]] = {label: [] for label in trees}
            for _ in range(args.repeat):
                for label, tree in trees.items():
                    times[label].append(wall_time(commands(tree, out)[name], tree))
            row = {"command": name, "runs": args.repeat,
                   **{f"{label}_median_s": round(statistics.median(t), 3) for label, t in times.items()}}
            if old is not None:
                row["ratio_new_over_old"] = round(row["new_median_s"] / row["old_median_s"], 3)
                row["base"] = args.base
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
