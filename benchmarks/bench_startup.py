"""Whole-process wall times a user waits for: ``agentic-mpc check`` of a scenario file and ``agentic-mpc run``
of the paper's Scenario 1 (``message_right``, 300 steps), median of N runs each (default 5).

    .venv/bin/python benchmarks/bench_startup.py [--repeat 5]

Prints one JSON line per command. Run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "agentic_mpc"]
S1 = REPO / "scenarios" / "paper_steering_preference.yaml"


def wall_times(command: list[str], repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO)
        times.append(time.perf_counter() - started)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as out:
        cases = {
            "check": [*CLI, "check", str(S1)],
            "run scenario 1 message_right": [*CLI, "run", str(S1), "--variant", "message_right", "--out", out],
            "run scenario 1 message_right, no figure": [
                sys.executable, "-c",
                "import sys; from agentic_mpc.scenario.schema import load_scenario; "
                "from agentic_mpc.scenario.runner import run_scenario; "
                "s = load_scenario(sys.argv[1]).variant('message_right'); "
                "run_scenario(s.model_copy(update={'outputs': s.outputs.model_copy(update={'plot': False})}), sys.argv[2])",
                str(S1), out,
            ],
            "python -c pass (the interpreter alone)": [sys.executable, "-c", "pass"],
        }
        for name, command in cases.items():
            times = wall_times(command, args.repeat)
            print(json.dumps({"command": name, "median_s": round(statistics.median(times), 3),
                              "min_s": round(min(times), 3), "runs": args.repeat}))


if __name__ == "__main__":
    main()
