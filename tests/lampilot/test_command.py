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


def test_the_crossroad_turns_as_told_and_a_scene_that_cannot_be_built_is_a_failure_the_rest_run(tmp_path, capsys):
    """LaMPilot's dt-intersection-v0 in SUMO with our own phrasings (the benchmark's are its to measure): a stop
    sign, cross traffic from both sides; the exit the command names. A pull-over scene with 8 lanes (held-out
    samples have 7 and 8) cannot be built: its case fails with the reason, the others run."""
    def intersection(exit_lane):
        return {"env": {"type": "dt-intersection-v0", "vehicles_count": 1, "num_vehicles_right": 1,
                        "num_vehicles_left": 1}, "eval": {"type": "IntersectionEval", "direction": ["il1", exit_lane, 0]},
                "seed": 7}
    for name, command, exit_lane in (("left", "Turn left once we get to the junction.", "o1"),
                                     ("right", "Take a right at the crossing, please.", "o3"),
                                     ("straight", "Straight on through the crossroads.", "o2")):
        (tmp_path / f"{name}.json").write_text(json.dumps({"commands": [command], "samples": [intersection(exit_lane)]}))
    wide = {"env": {"type": "dt-highway-v0", "num_lanes": 8, "vehicles_count": 0, "vehicles_density": 1.0,
                    "ego_vehicle": {"speed": 25, "start_lane_index": ["0", "1", 1], "start_position": [100, 0]}},
            "eval": {"type": "PullOverEval"}, "seed": 3}
    (tmp_path / "wide.json").write_text(json.dumps({"commands": ["Pull over."], "samples": [wide]}))
    assert main(["lampilot", str(tmp_path), "--out", str(tmp_path / "out"), "--workers", "2", "--no-progress"]) == 0
    cases = pd.read_csv(tmp_path / "out" / "cases.csv").set_index("task")
    for name in ("left", "right", "straight"):
        assert cases.loc[name, "success"] and not cases.loc[name, "collided"], cases.loc[name, "reason"]
    assert not cases.loc["wide", "success"] and cases.loc["wide", "status"] == "not run"
    assert "num_lanes 8" in cases.loc["wide", "reason"]
    assert "completion_pct" in capsys.readouterr().out


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


def test_own_phrasings_replace_a_tasks_commands_and_speeds_can_be_asked_past_the_limit(tmp_path, capsys):
    """``--phrasings`` runs the named tasks with the file's commands; ``--speed-requests as_asked`` lets a command
    ask past the road's 31.29 m/s as LaMPilot's highway-env does (lawful: the rules keep to the limit, say so)."""
    tasks = write_tasks(tmp_path / "tasks", ["speed_abs", "lane_left"])
    phrasings = tmp_path / "mine.yaml"
    phrasings.write_text("speed_abs: ['Cruise at 33 m/s.']\n")
    for mode, v_ref in (("lawful", 31.29), ("as_asked", 33)):
        out = tmp_path / mode
        assert main(["lampilot", str(tasks), "--out", str(out), "--phrasings", str(phrasings), "--scenes", "1",
                     "--speed-requests", mode, "--no-progress"]) in (0, 1)
        cases = pd.read_csv(out / "cases.csv")
        assert cases["task"].tolist() == ["speed_abs"] and cases["command"].tolist() == ["Cruise at 33 m/s."]
        events = pd.read_csv(next((out / "runs").rglob("events.csv")))
        applied = events[(events["event"] == "tool_call_received") & (events["tool"] == "set_reference_speed")]
        assert json.loads(applied["arguments"].iloc[0]) == {"v_ref": v_ref} and bool(applied["ok"].iloc[0])
        replies = " ".join(events[events["role"] == "assistant"]["content"].dropna())
        assert ("above the road speed limit" in replies) == (mode == "lawful")


@pytest.mark.parametrize(("text", "message"), [
    ("nope: ['Go.']\n", "'nope': no such task in the directory"),
    ("speed_abs: []\n", "'speed_abs': a non-empty list of phrasings"),
    ("[1, 2]\n", "a mapping of task names to lists of phrasings"),
])
def test_a_bad_phrasings_file_exits_2_naming_the_file_and_entry(tmp_path, capsys, text, message):
    tasks = write_tasks(tmp_path / "tasks", ["speed_abs"])
    (tmp_path / "mine.yaml").write_text(text)
    assert main(["lampilot", str(tasks), "--out", str(tmp_path / "out"), "--phrasings",
                 str(tmp_path / "mine.yaml")]) == 2
    err = capsys.readouterr().err
    assert "mine.yaml" in err and message in err and "Traceback" not in err


def test_a_model_backend_is_shown_lampilots_manoeuvres_unless_told_otherwise():
    from agentic_mpc.cli import build_parser
    from agentic_mpc.commands.lampilot import agent_for

    model = ["lampilot", "DIR", "--out", "OUT", "--backend", "openai", "--base-url", "http://127.0.0.1:1", "--model", "m"]
    assert agent_for(build_parser().parse_args(model))["toolset"] == "lampilot"
    assert agent_for(build_parser().parse_args([*model, "--agent", "toolset=all"]))["toolset"] == "all"
    assert "toolset" not in agent_for(build_parser().parse_args(["lampilot", "DIR", "--out", "OUT"]))  # the rules
