"""Issue 24's criteria from a batch of ``incident_in_traffic`` (and any runs with yields): per variant, the share
of runs that passed every stopped car they met within 60 s of reaching its queue, the longest ``stuck_s``,
collisions with the ego at fault, and, where the agent resumed after a stop, whether the ego got back to v_ref.

    python benchmarks/incident_outcomes.py out/batch [more batch dirs] [--misses]

``--misses`` also lists each run that misses one of the issue's bars (not past within 60 s, stuck over 10 s, a
contact at fault, not back at v_ref), to read one by one.

"Reaching the queue" of a stopped car: the first time the ego is slower than 2 m/s within 80 m behind it (a car
passed without slowing reached nothing: 0 s). A run that ends less than 60 s after reaching a queue it has not
yet passed is undecided: counted in ``undecided``, left out of ``passed_all_60s``. Reads each run's summary.csv, obstacle_passes.csv and
trajectory.csv; writes nothing.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pandas as pd

QUEUE_SPEED_MPS = 2.0
QUEUE_WINDOW_M = 80.0
PASS_WITHIN_S = 60.0
STUCK_BAR_S = 10.0


def run_outcome(run_dir: Path) -> dict:
    summary = pd.read_csv(run_dir / "summary.csv").iloc[0].to_dict()
    row = {k: summary.get(k) for k in ("scenario", "variant", "seed", "collisions_ego_at_fault", "stuck_s",
                                       "resume_to_v_ref_s", "ambulance_delay_s", "accel_rms_mps2", "jerk_rms_mps3")}
    if pd.isna(row.get("resume_to_v_ref_s")):  # written by older commits without the column: work it out
        from agentic_mpc.run.stuck import resume_to_v_ref_s

        speeds = pd.read_csv(run_dir / "trajectory.csv", usecols=["time_s", "v_mps", "v_ref_mps"])
        row["resume_to_v_ref_s"] = resume_to_v_ref_s(speeds["time_s"], speeds["v_mps"], speeds["v_ref_mps"])
    passes_file = run_dir / "obstacle_passes.csv"
    if not passes_file.exists():
        return row
    passes = pd.read_csv(passes_file)
    trajectory = pd.read_csv(run_dir / "trajectory.csv", usecols=["time_s", "road_s_m", "v_mps"])
    met = passes[passes["side"] != "behind at start"]
    worst, censored, end_s = 0.0, False, float(trajectory["time_s"].iloc[-1])
    for _, obstacle in met.iterrows():
        near = trajectory[(trajectory["road_s_m"] > obstacle["road_s_m"] - QUEUE_WINDOW_M)
                          & (trajectory["road_s_m"] < obstacle["road_s_m"]) & (trajectory["v_mps"] < QUEUE_SPEED_MPS)]
        reached = float(near["time_s"].iloc[0]) if len(near) else math.nan
        passed = float(obstacle["passed_at_s"])
        if math.isnan(passed):
            if len(near) and end_s - reached >= PASS_WITHIN_S:
                worst = math.inf  # met it and did not get past within the time
            elif len(near) or trajectory["road_s_m"].iloc[-1] > obstacle["road_s_m"] - QUEUE_WINDOW_M:
                censored = True  # the run ended less than 60 s after it reached the queue: undecided
            continue
        worst = max(worst, 0.0 if math.isnan(reached) else passed - reached)
    row["stopped_cars_met"] = len(met)
    row["worst_pass_s"] = worst
    row["undecided"] = censored and worst <= PASS_WITHIN_S
    row["passed_all_within_60s"] = math.nan if row["undecided"] else float(worst <= PASS_WITHIN_S)
    return row


def bars_in_total(table: pd.DataFrame) -> str:
    """The issue's bars over every run of ``table``, in one line (the closing notes' table rows)."""
    over = table["stuck_s"].gt(STUCK_BAR_S)
    parts = [f"{len(table)} runs"]
    if "passed_all_within_60s" in table:
        decided = table["passed_all_within_60s"].dropna()
        parts.append(f"passed every stopped car within {PASS_WITHIN_S:.0f} s: "
                     f"{int(decided.sum())}/{len(decided)} decided")
    parts.append(f"stuck over {STUCK_BAR_S:.0f} s: {int(over.sum())} (longest {table['stuck_s'].max():.2f} s)")
    parts.append(f"runs at fault: {int(table['collisions_ego_at_fault'].gt(0).sum())}")
    if "resumed_to_v_ref" in table:
        resumed = table["resumed_to_v_ref"].dropna()
        parts.append(f"resumes back at v_ref: {int(resumed.sum())}/{len(resumed)}")
    parts.append(f"accel RMS {table['accel_rms_mps2'].mean():.3f} m/s2, "
                 f"jerk RMS {table['jerk_rms_mps3'].mean():.3f} m/s3")
    return "all: " + "; ".join(parts)


def main(batch_dirs: list[str], misses: bool = False) -> None:
    rows = [run_outcome(summary.parent) for d in batch_dirs for summary in Path(d).glob("runs/*/*/seed-*/summary.csv")]
    table = pd.DataFrame(rows)
    aggregations = {"runs": ("seed", "count"), "at_fault": ("collisions_ego_at_fault", "sum"),
                    "stuck_s_max": ("stuck_s", "max"), "accel_rms": ("accel_rms_mps2", "mean"),
                    "jerk_rms": ("jerk_rms_mps3", "mean")}
    if "passed_all_within_60s" in table:
        aggregations["passed_all_60s"] = ("passed_all_within_60s", "mean")  # of the decided runs
        aggregations["undecided"] = ("undecided", "sum")
        aggregations["worst_pass_s_max"] = ("worst_pass_s", "max")
    if table["resume_to_v_ref_s"].notna().any():
        table["resumed_to_v_ref"] = table["resume_to_v_ref_s"].apply(lambda v: math.nan if pd.isna(v) else math.isfinite(v))
        aggregations["resumes"] = ("resume_to_v_ref_s", "count")
        aggregations["back_at_v_ref"] = ("resumed_to_v_ref", "mean")
        aggregations["resume_s_median"] = ("resume_to_v_ref_s", "median")
    print(table.groupby(["scenario", "variant"]).agg(**aggregations).round(3).to_string())
    print("\n" + bars_in_total(table))
    if misses:
        missed = table["stuck_s"].gt(STUCK_BAR_S) | table["collisions_ego_at_fault"].gt(0)
        if "passed_all_within_60s" in table:
            missed |= table["passed_all_within_60s"].eq(0.0)
        if "resumed_to_v_ref" in table:
            missed |= table["resumed_to_v_ref"].eq(0.0)
        columns = [c for c in ("variant", "seed", "worst_pass_s", "stuck_s", "collisions_ego_at_fault",
                               "resume_to_v_ref_s", "ambulance_delay_s") if c in table]
        print(f"\n{int(missed.sum())} runs miss a bar:")
        print(table[missed].sort_values(["variant", "seed"])[columns].round(2).to_string(index=False))


if __name__ == "__main__":
    arguments = [a for a in sys.argv[1:] if a != "--misses"]
    if not arguments:
        sys.exit("usage: python benchmarks/incident_outcomes.py BATCH_DIR [BATCH_DIR ...] [--misses]")
    main(arguments, misses="--misses" in sys.argv[1:])
