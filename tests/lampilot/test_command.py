"""``agentic-mpc lampilot``: one closed-loop case per task group in SUMO, cases.csv and the table, resuming,
and bad input refused before anything runs."""

import json

import pandas as pd
import pytest

from agentic_mpc.cli import main
from tests.lampilot.tasks import TASKS, write_tasks


def test_one_case_per_group_in_closed_loop_with_the_rules_backend(tmp_path, capsys):
    tasks = write_tasks(tmp_path / "tasks")
    out = tmp_path / "out"
    assert main(["lampilot", str(tasks), "--out", str(out), "--workers", "2", "--no-progress"]) == 0
    cases = pd.read_csv(out / "cases.csv")
    assert len(cases) == len(TASKS)
    assert set(cases["group"]) == {"speed", "following_distance", "lane_change", "overtake", "pull_over"}
    failed = cases[~cases["success"]]
    assert failed.empty, failed[["task", "reason"]].to_string()
    assert not cases["collided"].any() and (cases["score"] > 50).all()
    for row in cases.itertuples():
        assert (tmp_path / row.run_dir / "trajectory.csv").is_file() or (out / "runs").is_dir()
    table = pd.read_csv(out / "table.csv", index_col="group")
    assert table.loc["total", "completion_pct"] == 100.0 and table.loc["total", "cases"] == len(TASKS)
    printed = capsys.readouterr().out
    assert "completion_pct" in printed and "92.7" in printed
    # again: nothing runs, the same table
    assert main(["lampilot", str(tasks), "--out", str(out), "--workers", "2", "--no-progress"]) == 0
    assert f"0 ran now, {len(TASKS)} were already done" in capsys.readouterr().out
    assert pd.read_csv(out / "cases.csv")["success"].tolist() == cases["success"].tolist()


def test_intersections_are_listed_as_not_supported_and_count_as_failures(tmp_path, capsys):
    sample = {"env": {"type": "dt-intersection-v0", "vehicles_count": 1}, "eval": {"type": "IntersectionEval",
              "direction": ["il1", "o1", 0]}, "seed": 1}
    (tmp_path / "turn.json").write_text(json.dumps({"commands": ["Turn left here."], "samples": [sample]}))
    assert main(["lampilot", str(tmp_path), "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    cases = pd.read_csv(tmp_path / "out" / "cases.csv")
    assert cases["reason"].tolist() == ["not supported: the scene needs junctions"] and not cases["success"].any()
    assert "not supported" in capsys.readouterr().out


@pytest.mark.parametrize(("arguments", "message"), [
    (["--tasks", "nope"], "unknown task(s) nope"),
    (["--agent", "latency_s=-1"], "--agent latency_s"),
])
def test_bad_input_exits_2_naming_it(tmp_path, capsys, arguments, message):
    tasks = write_tasks(tmp_path / "tasks", ["lane_left"])
    assert main(["lampilot", str(tasks), "--out", str(tmp_path / "out"), *arguments]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out" / "cases.csv").exists()


def test_a_directory_with_a_broken_file_exits_2_naming_the_file(tmp_path, capsys):
    tasks = write_tasks(tmp_path / "tasks", ["lane_left"])
    (tasks / "broken.json").write_text('{"commands": ["Go."], "samples": [{"env": {"type": "moon-v0"}}]}')
    assert main(["lampilot", str(tasks), "--out", str(tmp_path / "out")]) == 2
    assert "broken.json: samples[0].env.type: unknown scene 'moon-v0'" in capsys.readouterr().err
