"""Run functions for the batch tests, imported by ``module:function`` in the batch's run processes.

They do real work in real processes: one drives the paper's Scenario 1 (no SUMO), the others die, raise or
wait in the ways a simulation can. Each appends ``<variant> <seed>`` to the file named by ``RUN_LOG_ENV``
when it starts, so a test can see which runs actually ran.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path
from typing import Any

RUN_LOG_ENV = "AGENTIC_MPC_TEST_RUN_LOG"
GATE_ENV = "AGENTIC_MPC_TEST_GATE_DIR"
GATE_TIMEOUT_S = 60.0


def _log_start(variant: str, seed: int) -> None:
    log = os.environ.get(RUN_LOG_ENV)
    if log:
        with open(log, "a", encoding="utf-8") as handle:  # O_APPEND: lines of parallel runs do not mix
            handle.write(f"{variant} {seed}\n")


def ran(log: Path) -> list[tuple[str, int]]:
    """The runs the run log shows, in order."""
    if not log.exists():
        return []
    return [(variant, int(seed)) for variant, seed in (line.split() for line in log.read_text().splitlines())]


PLAIN_SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper_steering_preference_plain.yaml"


def obstacle_run(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """Scenario 1 without traffic for ``duration_s`` of the file; variant names are the demo's variants."""
    _log_start(variant, seed)
    import pandas as pd

    import numpy as np

    from agentic_mpc.scenario.passing import analyse_pass
    from agentic_mpc.scenario.runner import drive
    from agentic_mpc.scenario.schema import load_scenario

    started = time.perf_counter()
    scenario = load_scenario(scenario_file).variant(variant)
    plain = load_scenario(PLAIN_SCENARIO)
    name = variant if variant in plain.variant_names else "no_message"
    loop = drive(plain.variant(name).with_seed(seed).model_copy(update={"duration_s": scenario.duration_s}))
    rows = pd.DataFrame(loop.recorder.trajectory_rows)
    states = np.vstack([rows[["x_m", "y_m", "phi_rad", "v_mps"]].to_numpy(), loop.world.ego_state])
    result = analyse_pass(states, loop.world.dt_s, loop.world.obstacle_circles()[0], loop.world.lanes().lanes["center"],
                          15.0)
    pd.DataFrame(states, columns=["x_m", "y_m", "phi_rad", "v_mps"]).assign(
        time_s=np.arange(len(states)) * loop.world.dt_s).to_csv(out_dir / "trajectory.csv", index=False)
    row = {
        "scenario": scenario.name, "variant": variant, "seed": seed, "status": "ok",
        "obstacle_side": result.side, "min_clearance_m": result.min_clearance_m,
        "final_x_m": float(states[-1, 0]), "pid": os.getpid(), "wall_s": round(time.perf_counter() - started, 3),
    }
    pd.DataFrame([row]).to_csv(out_dir / "summary.csv", index=False)  # as a run function does; the batch rewrites it
    return row


def quick_run(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """A run that only writes a file: for the batch's own machinery."""
    _log_start(variant, seed)
    (out_dir / "result.txt").write_text(f"{variant} {seed}\n")
    return {"scenario": "ignored: the batch names runs", "variant": variant, "seed": seed, "status": "ok",
            "seed_squared": seed * seed, "pid": os.getpid()}


def faulty_run(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """Seed 1 exits the process hard, seed 2 is killed by SIGKILL, seed 3 raises; the others succeed."""
    if seed == 1:
        _log_start(variant, seed)
        print("libsumo: giving up", flush=True)
        os._exit(3)
    if seed == 2:
        _log_start(variant, seed)
        os.kill(os.getpid(), signal.SIGKILL)
    if seed == 3:
        _log_start(variant, seed)
        raise ValueError(f"the ego left the road (seed {seed})")
    return quick_run(scenario_file, variant, seed, out_dir)


def gated_run(scenario_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """Seeds 0 and 1 finish at once; later seeds write ``started-<seed>`` (their pid) into the gate directory
    and wait until the test creates ``open`` there (for interrupting or killing a batch mid-run)."""
    if seed >= 2:
        gate = Path(os.environ[GATE_ENV])
        (gate / f"started-{seed}").write_text(str(os.getpid()))
        deadline = time.monotonic() + GATE_TIMEOUT_S
        while not (gate / "open").exists():
            if time.monotonic() > deadline:
                raise TimeoutError("the test never opened the gate")
            time.sleep(0.02)
    return quick_run(scenario_file, variant, seed, out_dir)
