"""The batch report's tables: per variant (collisions and those at the ego's fault), and the ambulance's delay
the ego causes, paired by seed."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from agentic_mpc.scenario.report import ambulance_pairs, main, variant_table


def summary_row(scenario: str, variant: str, seed: int, delay: float, collisions: int = 0, at_fault: int = 0,
                status: str = "ok") -> dict:
    return {"scenario": scenario, "variant": variant, "seed": seed, "status": status, "collisions": collisions,
            "collisions_ego_at_fault": at_fault, "obstacle_side": "", "min_obstacle_clearance_m": math.nan,
            "ambulance_delay_s": delay, "mean_speed_mps": 14.0, "lane_rms_error_m": 0.1, "agent_tool_calls": 1,
            "controller_ms_median": 3.0}


SUMMARY = pd.DataFrame([
    summary_row("emergency", "yield", 0, 4.0), summary_row("emergency", "no_message", 0, 13.0, 1, 0),
    summary_row("emergency", "yield", 1, 2.0, 2, 1), summary_row("emergency", "no_message", 1, 12.0),
    summary_row("emergency", "yield", 2, 3.0), summary_row("emergency", "no_message", 2, 9.0, status="failed"),
    summary_row("dense", "observation_messages", 0, 5.0), summary_row("dense", "unaware", 0, 6.0),
    summary_row("steering", "no_message", 0, math.nan), summary_row("steering", "message_left", 0, math.nan),
])


def test_the_variant_table_shows_collisions_and_those_at_fault():
    table = variant_table(SUMMARY)
    assert table.loc[("emergency", "yield"), "collisions"] == 2
    assert table.loc[("emergency", "yield"), "collisions_ego_at_fault"] == 1
    assert table.loc[("emergency", "no_message"), ["collisions", "collisions_ego_at_fault"]].tolist() == [1, 0]
    older = variant_table(SUMMARY.drop(columns="collisions_ego_at_fault"))  # a summary from before the column
    assert older["collisions_ego_at_fault"].isna().all() and older["collisions"].sum() == 3


def test_ambulance_pairs_by_seed_holding_minus_yielding():
    pairs = ambulance_pairs(SUMMARY)
    emergency = pairs[pairs["scenario"] == "emergency"]
    # seed 2's holding run failed: no pair
    assert emergency["seed"].tolist() == [0, 1]
    assert set(emergency["holding_variant"]) == {"no_message"} and set(emergency["yielding_variant"]) == {"yield"}
    assert emergency["delay_from_holding_s"].tolist() == [9.0, 10.0]
    assert emergency["delay_ratio"].tolist() == [pytest.approx(3.25), pytest.approx(6.0)]
    dense = pairs[pairs["scenario"] == "dense"].iloc[0]
    assert (dense["holding_variant"], dense["yielding_variant"], dense["delay_from_holding_s"]) == (
        "unaware", "observation_messages", 1.0)
    assert "steering" not in set(pairs["scenario"])  # no emergency vehicle, no delays


def test_the_holding_variant_can_be_named():
    pairs = ambulance_pairs(SUMMARY, holding={"emergency": "yield"})
    emergency = pairs[pairs["scenario"] == "emergency"]
    assert emergency["delay_from_holding_s"].tolist() == [-9.0, -10.0]


def test_a_scenario_without_a_holding_variant_gives_no_rows():
    renamed = SUMMARY.replace({"variant": {"no_message": "plan_a", "unaware": "plan_b"}})
    assert ambulance_pairs(renamed).empty


def test_the_command_prints_both_tables(tmp_path, capsys):
    path = tmp_path / "summary.csv"
    SUMMARY.to_csv(path, index=False)
    assert main([str(path)]) == 0
    out = capsys.readouterr().out
    assert "collisions_ego_at_fault" in out and "delay_from_holding_s" in out
