"""``agentic-mpc demo``: the paper's Scenario 1 without traffic (a plain-world scenario file), every variant
over several seeds.

Prints the table of pass sides, clearances and recovery times, and writes ``results.csv``,
``trajectories.png`` (the paper's Figure 3) and ``timeseries.png`` to ``--out``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agentic_mpc.commands import non_negative_int, positive_int, scenario_file
from agentic_mpc.shipped import scenarios_dir

DEFAULT_SCENARIO = scenarios_dir() / "paper_steering_preference_plain.yaml"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("demo", help="the paper's obstacle scenario without traffic", description=__doc__)
    parser.add_argument("--trials", type=positive_int, default=10, help="seeds per variant (the paper ran 10)")
    parser.add_argument("--first-seed", type=non_negative_int, default=0)
    parser.add_argument("--scenario", type=scenario_file, default=DEFAULT_SCENARIO,
                        help="a plain-world scenario file or shipped scenario's name")
    parser.add_argument("--out", type=Path, default=Path("out/obstacle_demo"), help="output directory")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np
    import pandas as pd

    from agentic_mpc import plots
    from agentic_mpc.scenario.passing import analyse_pass
    from agentic_mpc.scenario.report import obstacle_pass_columns
    from agentic_mpc.scenario.runner import drive
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.scenario.yaml_source import ScenarioFileError

    try:
        scenario_file = load_scenario(args.scenario)
    except ScenarioFileError as error:
        print(error, file=sys.stderr)
        return 2
    if scenario_file.base.plain_world is None or not scenario_file.base.plain_world.obstacles:
        print(f"{args.scenario}: the demo needs a plain_world scenario with an obstacle", file=sys.stderr)
        return 2
    rows, trajectories, series = [], {}, {}
    for variant in scenario_file.variant_names:
        trajectories[variant], series[variant] = [], []
        for seed in range(args.first_seed, args.first_seed + args.trials):
            loop = drive(scenario_file.variant(variant).with_seed(seed))
            records = pd.DataFrame(loop.recorder.trajectory_rows)
            states = np.vstack([records[["x_m", "y_m", "phi_rad", "v_mps"]].to_numpy(), loop.world.ego_state])
            tracking = loop.slot.current.get("path_tracking")
            obstacle = loop.world.obstacle_circles()[0]
            result = analyse_pass(states, loop.world.dt_s, obstacle, tracking.path, tracking.v_ref_mps)
            trajectories[variant].append(states)
            lateral = tracking.path.lateral_offset(states[:, 0], states[:, 1])
            series[variant].append((np.arange(len(states)) * loop.world.dt_s, states[:, 3], lateral))
            rows.append(
                {
                    "variant": variant,
                    "seed": seed,
                    "obstacle_side": result.side,
                    "min_obstacle_clearance_m": round(result.min_clearance_m, 3),
                    "recovery_s": round(result.recovery_s, 2),
                    "controller_ms_median": round(float(records["solve_ms"].median()), 3),
                }
            )
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "results.csv", index=False)
    summary = table.groupby("variant", sort=False).agg(
        **obstacle_pass_columns("left", "right"),
        max_recovery_s=("recovery_s", "max"),
        controller_ms=("controller_ms_median", "median"),
    )
    base = scenario_file.base
    tracked = base.specification.path_tracking
    print(f"{base.name}, {args.trials} seeds per variant (v_ref {tracked.v_ref_mps if tracked else '-'} m/s, obstacle "
          f"r = {obstacle.radius_m} m at {obstacle.x_m} m):")
    print(summary.to_string())
    lanes = loop.world.lanes().lanes
    plots.birds_eye(
        trajectories, list(lanes.values()), [obstacle], args.out / "trajectories.png",
        title="Scenario 1: grey no message, red 'avoid from the right', blue 'from the left'",
        x_range_m=(0, 110),
    )
    plots.time_series(series, args.out / "timeseries.png", v_ref_mps=tracked.v_ref_mps if tracked else None)
    print(f"wrote {args.out}/results.csv, trajectories.png, timeseries.png")
    return 0
