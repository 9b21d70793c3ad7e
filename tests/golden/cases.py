"""The golden runs: every shipped scenario file and variant (but the measurement-only ones below), seeds 0
and 1 (0 only where the variants differ in documents and handedness alone), shortened where long.

Their ``summary.csv``, ``trajectory.csv`` and ``events.csv`` (wall-clock columns aside) are kept under
``tests/golden/data/`` and must not change unless a change of behaviour is intended; then regenerate them
with ``python -m tests.golden.regenerate`` and say why in the commit.
"""

from __future__ import annotations

import csv
import io
import shutil
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"
SEEDS = (0, 1)
ONE_SEED = {
    # the variants differ in the jurisdiction's documents and the road's handedness, which seed 0 pins; a second
    # seed runs no other code and cost 7 traffic runs of the suite's time
    "emergency_by_jurisdiction",
    "speed_limits_by_jurisdiction",
}
FILES = ("summary.csv", "trajectory.csv", "events.csv")

DURATION_S = {
    # the paper's scenarios run whole; the traffic experiments (90 s of warm-up) are cut short, but the
    # ambulance one keeps long enough for the observation messages to wake the agent and for it to act
    "paper_steering_preference": None,
    "paper_emergency_response": None,
    "traffic_ambulance_dense": 125.0,
    "traffic_density_sweep": 100.0,
    "emergency_rescue_lane_traffic": 115.0,  # sublane traffic is SUMO's dearest step: the ambulance's approach
    "incident_in_traffic": 110.0,  # past the first stopped car (the second is measured, not pinned)
    "junction_osm_route": 190.0,  # 70 s of the route after the warm-up: lights, a turn, giving way
}

LEFT_OUT_VARIANTS = {
    # measurement variants that run no code the others do not (the ego placed elsewhere, the paper's stop at
    # another wake distance); each rescue-lane traffic run costs 20 s of the suite
    "emergency_rescue_lane": ("floor", "yield_stop"),
    "emergency_rescue_lane_traffic": ("floor", "yield_stop"),
    # the incident's variants differ in traffic density and the ambulance, which the traffic runs above pin
    "incident_in_traffic": ("dense_left", "dense_right", "ambulance_left", "ambulance_right", "dense_ambulance_left",
                            "dense_ambulance_right"),
}

WALL_CLOCK_COLUMNS = {
    "solve_ms", "step_ms", "wall_s", "controller_ms_median", "controller_ms_p95", "controller_ms_max",
    "step_ms_median", "step_ms_p95", "step_ms_max", "controller_ms_p99", "scenario_sha256",
}
"""Columns that measure the machine, not the behaviour (and the scenario file's hash, which a reformatted
file changes)."""


def shortened_scenarios(workdir: Path) -> list[Path]:
    """Copies of the shipped scenarios with the durations above, beside a link to the nets."""
    scenarios = workdir / "scenarios"
    scenarios.mkdir(parents=True, exist_ok=True)
    link = workdir / "sumo_nets"
    if not link.exists():
        link.symlink_to(REPO / "sumo_nets", target_is_directory=True)
    files = []
    for source in sorted((REPO / "scenarios").glob("*.yaml")):
        data = yaml.safe_load(source.read_text(encoding="utf-8"))
        if "simulation" not in data:
            continue  # worlds without SUMO are pinned by their own tests
        duration = DURATION_S.get(data["name"])
        if duration is not None:
            data["duration_s"] = duration
        for variant in LEFT_OUT_VARIANTS.get(data["name"], ()):
            data.get("variants", {}).pop(variant, None)
        target = scenarios / source.name
        target.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        files.append(target)
    return files


def comparable(path: Path) -> str:
    """A CSV's text without the wall-clock columns (values compared as written, to the last digit)."""
    rows = list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"))))
    if not rows:
        return ""
    keep = [i for i, name in enumerate(rows[0]) if name not in WALL_CLOCK_COLUMNS]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    for row in rows:
        writer.writerow([row[i] for i in keep if i < len(row)])
    return out.getvalue()


def run_all(workdir: Path) -> Path:
    """Run every golden case with the batch (a process per run); returns the batch's ``runs`` directory."""
    from agentic_mpc.batch import BatchSpec, run_batch

    files = shortened_scenarios(workdir)  # named after their scenarios
    batches = ((tuple(f for f in files if f.stem not in ONE_SEED), SEEDS, workdir / "out"),
               (tuple(f for f in files if f.stem in ONE_SEED), SEEDS[:1], workdir / "one_seed"))
    for chosen, seeds, out in batches:
        spec = BatchSpec(files=chosen, trials=len(seeds), first_seed=seeds[0], variants=None, workers=2,
                         out_dir=out, executor="process", scheduler=None)
        result = run_batch(spec, progress=False)
        failed = [row for row in result.rows if row["status"] != "ok"]
        if failed:
            raise RuntimeError(f"golden runs failed: {failed}")
    runs = workdir / "out" / "runs"
    for scenario in (workdir / "one_seed" / "runs").iterdir():  # one directory of cases, as stored
        shutil.move(scenario, runs / scenario.name)
    return runs


def cases(runs: Path) -> list[Path]:
    """The run directories below ``runs``, relative to it."""
    return sorted(p.parent.relative_to(runs) for p in runs.glob("*/*/seed-*/summary.csv"))


def store(runs: Path) -> None:
    shutil.rmtree(DATA, ignore_errors=True)
    for case in cases(runs):
        (DATA / case).mkdir(parents=True)
        for name in FILES:
            (DATA / case / name).write_text(comparable(runs / case / name), encoding="utf-8")
