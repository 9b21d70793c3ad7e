"""The paper's Scenario 1 without traffic (the obstacle demo), pinned state by state at seeds 0 and 1."""

from pathlib import Path

import numpy as np
import pytest

from agentic_mpc.obstacle_demo import VARIANTS, run_obstacle_variant

DATA = Path(__file__).resolve().parent / "data_plain"


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("seed", [0, 1])
def test_plain_world_trajectory_is_unchanged(variant, seed):
    expected = np.loadtxt(DATA / f"{variant}-seed-{seed}.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(run_obstacle_variant(variant, seed).state_array, expected)
