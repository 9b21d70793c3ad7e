"""The paper's Scenario 1 without traffic (the plain-world scenario file), pinned state by state at seeds 0
and 1: the states the old obstacle demo produced before the redesign."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from agentic_mpc.scenario.runner import drive
from agentic_mpc.scenario.schema import load_scenario

DATA = Path(__file__).resolve().parent / "data_plain"
SCENARIO = load_scenario(Path(__file__).resolve().parents[2] / "scenarios/paper_steering_preference_plain.yaml")


@pytest.mark.parametrize("variant", ["no_message", "message_right", "message_left"])
@pytest.mark.parametrize("seed", [0, 1])
def test_plain_world_trajectory_is_unchanged(variant, seed):
    expected = np.loadtxt(DATA / f"{variant}-seed-{seed}.csv", delimiter=",", skiprows=1)
    loop = drive(SCENARIO.variant(variant).with_seed(seed))
    rows = pd.DataFrame(loop.recorder.trajectory_rows)[["x_m", "y_m", "phi_rad", "v_mps"]].to_numpy()
    np.testing.assert_array_equal(np.vstack([rows, loop.world.ego_state]), expected)
