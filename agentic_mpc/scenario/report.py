"""The tables of a batch's ``summary.csv``: ``python -m agentic_mpc.scenario.report FILE``.

- :func:`variant_table`: one row per scenario and variant (means over seeds);
- :func:`ambulance_pairs`: the ambulance's delay the ego causes, per seed: the same seed run with the ego
  holding its lane and with it yielding (see :data:`HOLDING_VARIANTS` for which variant is which).
"""

from __future__ import annotations

import math
import sys
from typing import Any

import pandas as pd

HOLDING_VARIANTS = ("no_message", "unaware", "hold", "holding")
"""The variant in which the ego holds its lane (nobody tells the agent of the ambulance, or nobody wakes it):
the first variant of a scenario whose name is one of these. Every other variant of that scenario counts as
yielding and is compared with it seed by seed (the shipped ones: ``yield`` and ``observation_messages``)."""

PAIR_COLUMNS = ("scenario", "seed", "holding_variant", "yielding_variant", "holding_delay_s", "yielding_delay_s",
                "delay_from_holding_s", "delay_ratio")


def obstacle_pass_columns(left: str = "passed_left", right: str = "passed_right") -> dict[str, tuple[str, Any]]:
    """``DataFrame.agg`` columns of how the runs passed the obstacle: on each side, into it, the least clearance."""

    def runs_passed(side: str) -> Any:
        return lambda sides: int((sides == side).sum())

    return {left: ("obstacle_side", runs_passed("left")), right: ("obstacle_side", runs_passed("right")),
            "hit": ("obstacle_side", runs_passed("hit")), "min_clearance_m": ("min_obstacle_clearance_m", "min")}


def variant_table(summary: pd.DataFrame) -> pd.DataFrame:
    """One row per scenario and variant: runs, outcomes, and the means of the main metrics."""
    # older summaries lack these
    for column in ("accel_rms_mps2", "cruise_accel_rms_mps2", "ess_median_fraction", "collisions_ego_at_fault",
                   "stuck_s", "blockages_passed"):
        if column not in summary:
            summary = summary.assign(**{column: float("nan")})
    grouped = summary.groupby(["scenario", "variant"], sort=False)
    table = grouped.agg(
        runs=("seed", "count"),
        ok=("status", lambda s: int((s == "ok").sum())),
        collisions=("collisions", "sum"),
        collisions_ego_at_fault=("collisions_ego_at_fault", lambda s: s.sum(min_count=1)),
        **obstacle_pass_columns(),
        blockages_passed=("blockages_passed", "mean"),
        stuck_s_max=("stuck_s", "max"),
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


def ambulance_pairs(summary: pd.DataFrame, holding: dict[str, str] | None = None) -> pd.DataFrame:
    """Per scenario with an emergency vehicle, per seed and yielding variant: the ambulance's time loss with
    the ego holding and yielding, their difference (holding - yielding: the delay the ego causes by not making
    way) and ratio. ``holding`` overrides :data:`HOLDING_VARIANTS` per scenario (name -> variant). Runs that
    failed or have no delay are left out; a scenario without a holding variant gives no rows."""
    rows = []
    ok = summary[(summary["status"] == "ok") & summary["ambulance_delay_s"].notna()]
    for scenario, runs in ok.groupby("scenario", sort=False):
        variants = list(dict.fromkeys(summary.loc[summary["scenario"] == scenario, "variant"]))
        chosen = (holding or {}).get(str(scenario)) or next((v for v in variants if v in HOLDING_VARIANTS), None)
        if chosen is None:
            continue
        base = runs[runs["variant"] == chosen].set_index("seed")["ambulance_delay_s"]
        for variant in (v for v in variants if v != chosen):
            other = runs[runs["variant"] == variant].set_index("seed")["ambulance_delay_s"]
            for seed in sorted(set(base.index) & set(other.index)):
                held, yielded = float(base[seed]), float(other[seed])
                rows.append((scenario, int(seed), chosen, variant, held, yielded, round(held - yielded, 3),
                             round(held / yielded, 3) if yielded > 0 else math.nan))
    return pd.DataFrame(rows, columns=list(PAIR_COLUMNS))


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python -m agentic_mpc.scenario.report SUMMARY_CSV", file=sys.stderr)
        return 2
    summary = pd.read_csv(argv[0])
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(variant_table(summary).to_string())
        pairs = ambulance_pairs(summary)
        if len(pairs):
            print("\nambulance delay the ego causes by holding (same seed, holding - yielding):")
            print(pairs.to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
