"""Regenerate the golden CSVs (``python -m tests.golden.regenerate``) after an intended change of behaviour:
the SUMO runs of ``cases.py`` and the plain-world states of ``test_golden_plain.py``."""

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from agentic_mpc.scenario.runner import drive
from tests.golden.cases import DATA, run_all, store
from tests.golden.test_golden_plain import DATA as DATA_PLAIN
from tests.golden.test_golden_plain import SCENARIO as PLAIN_SCENARIO


def store_plain() -> None:
    """Every plain-world variant at seeds 0 and 1: the states of each step and the final one."""
    for variant in PLAIN_SCENARIO.variant_names:
        for seed in (0, 1):
            loop = drive(PLAIN_SCENARIO.variant(variant).with_seed(seed))
            rows = pd.DataFrame(loop.recorder.trajectory_rows)[["x_m", "y_m", "phi_rad", "v_mps"]].to_numpy()
            states = np.vstack([rows, loop.world.ego_state])
            np.savetxt(DATA_PLAIN / f"{variant}-seed-{seed}.csv", states, delimiter=",",
                       header="x_m,y_m,phi_rad,v_mps", comments="", fmt="%.17g")


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as workdir:
        store(run_all(Path(workdir)))
    store_plain()
    print(f"wrote {DATA} and {DATA_PLAIN}")
