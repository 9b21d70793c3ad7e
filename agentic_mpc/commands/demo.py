"""``agentic-mpc demo``: the paper's Scenario 1 without traffic, every variant over several seeds.

Prints the table of pass sides, clearances and recovery times, and writes ``results.csv``,
``trajectories.png`` (the paper's Figure 3) and ``timeseries.png`` to ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agentic_mpc.commands import positive_int


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("demo", help="the paper's obstacle scenario without traffic", description=__doc__)
    parser.add_argument("--trials", type=positive_int, default=10, help="seeds per variant (the paper ran 10)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("out/obstacle_demo"), help="output directory")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    import pandas as pd

    from agentic_mpc import plots
    from agentic_mpc.obstacle_demo import VARIANTS, ObstacleScene, analyse_pass, run_obstacle_variant

    scene = ObstacleScene()
    rows, trajectories, series = [], {}, {}
    for variant in VARIANTS:
        trajectories[variant], series[variant] = [], []
        for seed in range(args.first_seed, args.first_seed + args.trials):
            trajectory = run_obstacle_variant(variant, seed, scene)
            result = analyse_pass(trajectory, scene)
            states = trajectory.state_array
            trajectories[variant].append(states)
            lateral = scene.centre_lane.lateral_offset(states[:, 0], states[:, 1])
            series[variant].append((trajectory.time_s, states[:, 3], lateral))
            rows.append(
                {
                    "variant": variant,
                    "seed": seed,
                    "obstacle_side": result.side,
                    "min_obstacle_clearance_m": round(result.min_clearance_m, 3),
                    "recovery_s": round(result.recovery_s, 2),
                    "controller_ms_median": round(float(pd.Series(trajectory.solve_ms).median()), 3),
                }
            )
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "results.csv", index=False)
    summary = table.groupby("variant", sort=False).agg(
        left=("obstacle_side", lambda s: int((s == "left").sum())),
        right=("obstacle_side", lambda s: int((s == "right").sum())),
        hit=("obstacle_side", lambda s: int((s == "hit").sum())),
        min_clearance_m=("min_obstacle_clearance_m", "min"),
        max_recovery_s=("recovery_s", "max"),
        controller_ms=("controller_ms_median", "median"),
    )
    print(f"Scenario 1 without traffic, {args.trials} seeds per variant (v_ref 15 m/s, obstacle r = "
          f"{scene.obstacle_radius_m} m at {scene.obstacle_ahead_m} m):")
    print(summary.to_string())
    plots.birds_eye(
        trajectories, [scene.centre_lane, scene.left_lane], [scene.obstacle], args.out / "trajectories.png",
        title="Scenario 1: grey no message, red 'avoid from the right', blue 'from the left'",
        x_range_m=(0, 110),
    )
    plots.time_series(series, args.out / "timeseries.png", v_ref_mps=scene.v_ref_mps)
    print(f"wrote {args.out}/results.csv, trajectories.png, timeseries.png")
    return 0
