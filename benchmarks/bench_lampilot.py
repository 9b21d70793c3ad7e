"""LaMPilot cases: one case's run as a process, and a batch's cases per minute on 1 and 2 workers.

    .venv/bin/python benchmarks/bench_lampilot.py DIR [--per-task 1] [--tasks ...]

DIR is a LaMPilot-format directory (the tuning half: ../shared/benchmarks/lampilot/DbLv1). It runs
``agentic-mpc lampilot`` with the rules backend into a fresh temporary directory twice, with ``--workers 1``
and ``--workers 2``, and prints one JSON object: the cases, the wall time and cases per minute of each, the
speed-up of 2 workers over 1 (measured in this run), and per case (from ``summary.csv``): the median wall time
of its run process and the median simulated seconds per wall second (how much faster than real time a case
runs, warm-up and start included). BLAS is pinned to one thread.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def batch(directory: Path, out: Path, workers: int, extra: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "agentic_mpc", "lampilot", str(directory), "--out", str(out),
                    "--workers", str(workers), "--no-progress", *extra], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", type=Path)
    parser.add_argument("--per-task", type=int, default=1)
    parser.add_argument("--tasks", nargs="+", default=None)
    args = parser.parse_args()
    os.environ.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    extra = ["--per-task", str(args.per_task)] + (["--tasks", *args.tasks] if args.tasks else [])
    import pandas as pd

    result: dict = {}
    with tempfile.TemporaryDirectory() as temp:
        for workers in (1, 2):
            out = Path(temp) / f"w{workers}"
            wall_s = batch(args.directory, out, workers, extra)
            summary = pd.read_csv(out / "summary.csv")
            ran = summary[summary["status"] == "ok"]
            result[f"workers_{workers}"] = {"cases": len(ran), "wall_s": round(wall_s, 2),
                                            "cases_per_minute": round(60.0 * len(ran) / wall_s, 1)}
            if workers == 1:
                result["case_wall_s_median"] = round(float(ran["wall_s"].median()), 3)
                result["case_sim_s_per_wall_s_median"] = round(float((ran["sim_time_s"] / ran["wall_s"]).median()), 1)
    result["speedup_2_over_1"] = round(result["workers_2"]["cases_per_minute"] / result["workers_1"]["cases_per_minute"], 2)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
