"""Ride comfort and solver health of the released controller ("before") and the default one ("after").

Runs the shipped SUMO scenarios over seeds never used for tuning (5000 and up) with both configurations and
prints the medians over seeds (docs/cost-design.md has the table this wrote). Two processes at a time;
about 7 minutes on 2 cores.

    .venv/bin/python benchmarks/comfort_before_after.py [--seeds 20] [--out out/comfort]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
BEFORE = {
    "controller": {"first_input_noise": "paper", "harmonic_std_scale": 1.0, "ess_band": None},
    "mandatory": {"throttle_brake_smoothness_weight": 0.0, "steer_smoothness_weight": 0.0, "brake_effort_weight": 0.0},
}
RUNS = [  # file, variant, how many of the seeds
    ("paper_steering_preference.yaml", "no_message", 20),
    ("paper_steering_preference.yaml", "message_left", 20),
    ("paper_steering_preference.yaml", "message_right", 20),
    ("paper_emergency_response.yaml", "no_message", 10),
    ("paper_emergency_response.yaml", "yield", 10),
    ("traffic_ambulance_dense.yaml", "unaware", 3),
    ("traffic_density_sweep.yaml", "light", 3),
]
COLUMNS = ["obstacle_side", "min_obstacle_clearance_m", "accel_rms_mps2", "jerk_rms_mps3", "brake_fraction",
           "steer_rate_rms", "ess_median_fraction", "cruise_fraction", "cruise_accel_rms_mps2", "cruise_jerk_rms_mps3",
           "cruise_brake_fraction", "cruise_lateral_rms_m", "cruise_speed_error_max_mps", "obstacle_accel_rms_mps2",
           "obstacle_recovery_s", "collisions", "status", "error"]


def one_run(job: tuple[str, str, int, str]) -> dict:
    from agentic_mpc.scenario.runner import run_scenario
    from agentic_mpc.scenario.schema import load_scenario

    file, variant, seed, configuration = job
    scenario = load_scenario(SCENARIOS / file).variant(variant).with_seed(seed)
    update = {"outputs": scenario.outputs.model_copy(update={"plot": False, "replay": False})}
    if configuration == "before":
        spec = scenario.specification
        update["controller"] = scenario.controller.model_copy(update=BEFORE["controller"])
        update["specification"] = spec.model_copy(update={"mandatory": {**spec.mandatory, **BEFORE["mandatory"]}})
    with tempfile.TemporaryDirectory() as out_dir:
        row = run_scenario(scenario.model_copy(update=update), Path(out_dir))
    return {"configuration": configuration, "file": file, "variant": variant, "seed": seed,
            **{c: row.get(c) for c in COLUMNS}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20, help="at most this many seeds per variant, from 5000")
    parser.add_argument("--out", type=Path, default=Path("out/comfort"))
    args = parser.parse_args()
    import pandas as pd

    jobs = [(file, variant, 5000 + k, configuration) for configuration in ("before", "after")
            for file, variant, count in RUNS for k in range(min(count, args.seeds))]
    with ProcessPoolExecutor(2, max_tasks_per_child=8) as pool:
        table = pd.DataFrame(pool.map(one_run, jobs))
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "runs.csv", index=False)
    numbers = table.drop(columns=["seed"]).groupby(["file", "variant", "configuration"]).median(numeric_only=True)
    numbers.round(4).to_csv(args.out / "medians.csv")
    pd.set_option("display.width", 250)
    print(numbers.round(3).to_string())
    print(table.groupby(["file", "variant", "configuration"])["obstacle_side"].value_counts().to_string())
    print(f"wrote {args.out}/runs.csv and medians.csv")


if __name__ == "__main__":
    main()
