"""A yield in dense traffic stops in a lane, not across a lane line (J0's lane lines, ``SurroundingsConfig.lane_lines``).

Seed 2108 of ``incident_in_traffic`` ``dense_ambulance_left`` (docs/traffic.md, "Standing across a lane line"): asked
to make way (``run_right_lane(0)``) at 9 m/s, the ego steered for the edge lane, whose cars crawled nose to tail at
1-2 m/s, braked at full lock and stood with its centre 0.15 m from the line and its tail in the centre lane, where the
ambulance brushed it (the ego at fault). With the lines in J0 it stands at the centre lane's right side, as SUMO's
drivers there do for the rescue lane."""

from __future__ import annotations

import pandas as pd
import pytest

from agentic_mpc.scenario.runner import run_scenario
from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.shipped import scenario_path

LANE_HALF_WIDTH_M = 1.75  # the centre lane's line with the edge lane is this far right of its centre


def _run(tmp_path, lane_lines: bool) -> tuple[pd.DataFrame, pd.DataFrame]:
    scenario = load_scenario(scenario_path("incident_in_traffic")).variant("dense_ambulance_left").with_seed(2108)
    outputs = scenario.outputs.model_copy(update={"replay": False, "plot": False})
    surroundings = scenario.world.surroundings.model_copy(update={"lane_lines": lane_lines})
    world = scenario.world.model_copy(update={"surroundings": surroundings})
    scenario = scenario.model_copy(update={"duration_s": 104.0, "outputs": outputs, "world": world})
    out = tmp_path / str(lane_lines)
    run_scenario(scenario, out)
    return pd.read_csv(out / "trajectory.csv"), pd.read_csv(out / "events.csv")


def _centre_from_the_line_m(row: pd.Series) -> float:
    """How far the ego's centre is from the line between the centre and the edge lane (+: in the centre lane)."""
    if row.lane_index == 1:
        return LANE_HALF_WIDTH_M + row.lateral_offset_m
    return LANE_HALF_WIDTH_M - row.lateral_offset_m


@pytest.mark.slow
def test_a_yield_that_cannot_get_into_the_edge_lane_stands_in_its_own(tmp_path):
    results = {lines: _run(tmp_path, lines) for lines in (False, True)}
    for lines, (trajectory, events) in results.items():
        standing = trajectory[(trajectory.time_s >= 99.5) & (trajectory.time_s <= 100.5)]
        assert (standing.v_mps < 0.05).all() and (standing.tracked_lane == "right").all()
        faults = events[(events.event == "collision") & events.content.str.contains("ego at fault", regex=False)]
        from_line_m = _centre_from_the_line_m(standing.iloc[-1])
        print(f"\nlane lines {'on' if lines else 'off'}: standing at 100 s with the centre {from_line_m:.2f} m from "
              f"the line (lane {standing.iloc[-1].lane_index}); contacts at fault by 104 s: {len(faults)}")
        if lines:
            assert from_line_m > 0.8 and standing.iloc[-1].lane_index == 1  # the body (0.9 m half width) at the line
            assert faults.empty
        else:
            assert abs(from_line_m) < 0.5  # astride the line
            assert len(faults) == 1
