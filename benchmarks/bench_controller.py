"""Controller step timings over a grid of horizons and sample counts (run on demand, not in tests).

    .venv/bin/python benchmarks/bench_controller.py            # prints a markdown table
Each row runs ``agentic-mpc bench`` in a fresh process, so start-up (import + first compile or cache load)
is measured too. BLAS is pinned to one thread. Record results in benchmarks/README.md.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

GRID = [(50, 256, "fast"), (50, 256, "reference"), (50, 1024, "fast"), (100, 4096, "fast")]


def main() -> None:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    print("| H | S | backend | median ms | p10 ms | p90 ms | real-time factor | start-up s |")
    print("|---|---|---|---|---|---|---|---|")
    for horizon, samples, backend in GRID:
        steps = "300" if samples * horizon < 100_000 else "150"
        out = subprocess.run(
            [sys.executable, "-m", "agentic_mpc", "bench", "--horizon", str(horizon), "--samples", str(samples),
             "--steps", steps, "--backend", backend, "--json"],
            check=True, capture_output=True, text=True, env=env,
        ).stdout
        r = json.loads(out)
        print(f"| {horizon} | {samples} | {backend} | {r['median_ms']:.3f} | {r['p10_ms']:.3f} | {r['p90_ms']:.3f} "
              f"| {r['realtime_factor']:.0f} | {r['startup_s']:.2f} |")


if __name__ == "__main__":
    main()
