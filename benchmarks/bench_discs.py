"""J0's traffic discs in the fused kernel: this working tree against another commit, in one run.

    .venv/bin/python benchmarks/bench_discs.py [--base REV] [--discs 30] [--rounds 7]

Times ``FourierMPPI.costs`` (sampling aside: rollout and scoring of S = 256 samples over H = 50) for J0 + J1 with
``--discs`` moving discs around the ego's path, in fresh processes from each tree in turn (BLAS and Numba on
one thread), and prints the median of each round and the ratio new / old. The discs carry headings where the
tree knows them (``MovingDisc.headings``), so the new tree pays for the ego-heading growth. Idle machine.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

from worktree import REPO, checkout, environment

CHILD = r"""
import dataclasses, json, sys, time
import numpy as np
from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import MovingDisc, PathTracking, Specification, Surroundings

n_discs, steps = int(sys.argv[1]), int(sys.argv[2])
controller = FourierMPPI(MPPIConfig(horizon=50, samples=256), seed=0)
h = controller.config.horizon
k = np.arange(1, h + 1)[:, None]
fields = {f.name for f in dataclasses.fields(MovingDisc)}
discs = []
for i in range(n_discs):  # cars alongside and ahead in the next lanes, some turned a little
    angle = 0.05 * ((i % 5) - 2)
    centres = np.hstack([5.0 + 4.0 * i + 12.0 * 0.04 * k, np.full_like(k, 3.5 if i % 2 else -3.5, dtype=float)])
    extra = {}
    if "headings" in fields:
        extra = {"headings": np.tile([np.cos(angle), np.sin(angle)], (h, 1)), "ego_half_extents_m": (2.6, 0.95),
                 "body_radius_m": 2.35}
    discs.append(MovingDisc(centres, 2.65, **extra))
spec = Specification.of(PathTracking(path=LanePath.straight((-20.0, 0.0), (400.0, 0.0)), v_ref_mps=15.0))
state = np.array([0.0, 0.0, 0.0, 14.0])
prepared = spec.prepare(controller.context(state, Surroundings(moving_discs=tuple(discs))))
z = controller.sample().copy()
controller.costs(prepared, state, z)  # compile
times = []
for _ in range(steps):
    t0 = time.perf_counter()
    controller.costs(prepared, state, z)
    times.append(time.perf_counter() - t0)
print(json.dumps({"median_ms": 1e3 * float(np.median(times))}))
"""


def run(tree, args) -> float:
    out = subprocess.run([sys.executable, "-c", CHILD, str(args.discs), str(args.steps)], check=True,
                         capture_output=True, text=True, env=environment(tree), cwd=tree).stdout
    return json.loads(out)["median_ms"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="f7a4f80")
    parser.add_argument("--discs", type=int, default=30)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--steps", type=int, default=400)
    args = parser.parse_args()
    new, old = [], []
    with checkout(args.base) as old_tree:
        for round_ in range(args.rounds):
            new.append(run(REPO, args))
            old.append(run(old_tree, args))
            print(f"round {round_ + 1}: new {new[-1]:.3f} ms, old {old[-1]:.3f} ms")
    n, o = statistics.median(new), statistics.median(old)
    print(f"{args.discs} discs, S=256, H=50: new {n:.3f} ms, {args.base} {o:.3f} ms, ratio new/old {n / o:.2f}")


if __name__ == "__main__":
    main()
