"""The per-variant table of a batch's ``summary.csv``: ``python -m agentic_mpc.scenario.report FILE``."""

from __future__ import annotations

import sys

import pandas as pd


def variant_table(summary: pd.DataFrame) -> pd.DataFrame:
    """One row per scenario and variant: runs, outcomes, and the means of the main metrics."""
    for column in ("accel_rms_mps2", "cruise_accel_rms_mps2", "ess_median_fraction"):  # older summaries lack them
        if column not in summary:
            summary = summary.assign(**{column: float("nan")})
    grouped = summary.groupby(["scenario", "variant"], sort=False)
    table = grouped.agg(
        runs=("seed", "count"),
        ok=("status", lambda s: int((s == "ok").sum())),
        collisions=("collisions", "sum"),
        passed_left=("obstacle_side", lambda s: int((s == "left").sum())),
        passed_right=("obstacle_side", lambda s: int((s == "right").sum())),
        hit=("obstacle_side", lambda s: int((s == "hit").sum())),
        min_clearance_m=("min_obstacle_clearance_m", "min"),
        ambulance_delay_s=("ambulance_delay_s", "mean"),
        mean_speed_mps=("mean_speed_mps", "mean"),
        lane_rms_error_m=("lane_rms_error_m", "mean"),
        accel_rms_mps2=("accel_rms_mps2", "mean"),
        cruise_accel_rms_mps2=("cruise_accel_rms_mps2", "mean"),
        ess_share=("ess_median_fraction", "median"),
        tool_calls=("agent_tool_calls", "mean"),
        controller_ms=("controller_ms_median", "median"),
    )
    return table.round(3)


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python -m agentic_mpc.scenario.report SUMMARY_CSV", file=sys.stderr)
        return 2
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(variant_table(pd.read_csv(argv[0])).to_string())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
