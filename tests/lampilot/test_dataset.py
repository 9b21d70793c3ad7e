"""Reading a LaMPilot-format directory: every problem named with its file and field, before anything runs."""

import json

import pytest

from agentic_mpc.lampilot.dataset import LampilotInputError, load_tasks, select_cases
from tests.lampilot.tasks import motorway_env, write_tasks


def test_tasks_load_sorted_with_their_groups(tmp_path):
    tasks = load_tasks(write_tasks(tmp_path))
    assert [t.name for t in tasks] == sorted(t.name for t in tasks)
    groups = {t.name: t.group for t in tasks}
    assert groups["gap_abs"] == "following_distance" and groups["shoulder"] == "pull_over"
    assert [t.name for t in load_tasks(tmp_path, ["shoulder", "lane_left"])] == ["shoulder", "lane_left"]


def write(path, data):
    path.write_text(data if isinstance(data, str) else json.dumps(data))


@pytest.mark.parametrize(("content", "message"), [
    ("{not json", "bad.json: not a JSON file"),
    ([1, 2], "bad.json: a task file is a JSON object"),
    ({"commands": [], "samples": []}, "bad.json: commands: a non-empty list"),
    ({"commands": ["Go."], "samples": [{"env": {"type": "racetrack-v0"}, "eval": {"type": "PullOverEval"}, "seed": 1}]},
     "bad.json: samples[0].env.type: unknown scene 'racetrack-v0'"),
    ({"commands": ["Go."], "samples": [{"env": motorway_env(), "eval": {"type": "FlyEval"}, "seed": 1}]},
     "bad.json: samples[0].eval.type: unknown criterion 'FlyEval'"),
    ({"commands": ["Go."], "samples": [{"env": motorway_env(), "eval": {"type": "ACCEvalbySpeed"}, "seed": 1}]},
     "bad.json: samples[0].eval: ACCEvalbySpeed needs speed or rel_speed"),
    ({"commands": ["Go."], "samples": [{"env": {**motorway_env(), "vehicles_density": "dense"},
                                        "eval": {"type": "PullOverEval"}, "seed": 1}]},
     "bad.json: samples[0].env.vehicles_density: a non-negative number"),
    ({"commands": ["Go."], "samples": [{"env": motorway_env(), "eval": {"type": "PullOverEval"}, "seed": -3}]},
     "bad.json: samples[0].seed: a non-negative integer"),
])
def test_a_malformed_file_is_an_error_naming_the_file_and_field(tmp_path, content, message):
    write(tmp_path / "bad.json", content)
    with pytest.raises(LampilotInputError) as error:
        load_tasks(tmp_path)
    assert any(message in problem for problem in error.value.problems), error.value.problems


def test_a_missing_directory_and_unknown_tasks_are_errors(tmp_path):
    with pytest.raises(LampilotInputError, match="not a directory"):
        load_tasks(tmp_path / "nowhere")
    with pytest.raises(LampilotInputError, match="unknown task"):
        load_tasks(write_tasks(tmp_path), ["no_such_task"])


def test_per_task_spreads_over_phrasings_and_scenes_in_a_fixed_order(tmp_path):
    samples = [{"env": motorway_env(), "eval": {"type": "LaneChangeEval", "direction": "left"}, "seed": s}
               for s in range(4)]
    write(tmp_path / "t.json", {"commands": ["a", "b", "c"], "samples": samples})
    tasks = load_tasks(tmp_path)
    every = select_cases(tasks)
    assert len(every) == 12 and len({(c.command_index, c.sample_index) for c in every}) == 12
    chosen = select_cases(tasks, 5)
    pairs = [(c.command_index, c.sample_index) for c in chosen]
    assert len(set(pairs)) == 5 and {c for c, _ in pairs} == {0, 1, 2} and len({s for _, s in pairs}) >= 3
    assert pairs == [(c.command_index, c.sample_index) for c in select_cases(tasks, 5)]
