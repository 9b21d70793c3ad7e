"""The ``agentic-mpc`` command as a user runs it: a separate process, real output files."""

import json
import subprocess
import sys

import pandas as pd
import pytest


def agentic_mpc(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "agentic_mpc", *args], capture_output=True, text=True, timeout=300)


def test_bench_prints_one_json_object():
    result = agentic_mpc("bench", "--horizon", "20", "--samples", "64", "--steps", "30", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    for key in ("median_ms", "p10_ms", "p90_ms", "realtime_factor", "startup_s"):
        assert report[key] > 0
    assert report["p10_ms"] <= report["median_ms"] <= report["p90_ms"]
    assert report["realtime_factor"] == pytest.approx(40.0 / report["median_ms"], rel=2e-3)


def test_bench_rejects_zero_steps():
    result = agentic_mpc("bench", "--steps", "0")
    assert result.returncode != 0 and "--steps" in result.stderr


def test_demo_prints_the_table_and_writes_csv_and_figures(tmp_path):
    result = agentic_mpc("demo", "--trials", "2", "--first-seed", "3000", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "message_right" in result.stdout and "max_recovery_s" in result.stdout
    table = pd.read_csv(tmp_path / "results.csv")
    assert len(table) == 6 and set(table["variant"]) == {"no_message", "message_right", "message_left"}
    assert (table.loc[table.variant == "message_right", "obstacle_side"] == "right").all()
    assert (tmp_path / "trajectories.png").stat().st_size > 10_000
    assert (tmp_path / "timeseries.png").stat().st_size > 10_000


def test_replay_is_a_command_and_batch_replay_refuses_a_custom_runner(tmp_path):
    assert "replay" in agentic_mpc("--help").stdout
    result = agentic_mpc("batch", "scenarios/paper_steering_preference_plain.yaml", "--trials", "1", "--replay",
                         "--runner", "tests.batch.fake_runner:run", "--out", str(tmp_path))
    assert result.returncode == 2 and "--replay" in result.stderr
