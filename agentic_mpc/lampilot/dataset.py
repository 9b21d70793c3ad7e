"""A LaMPilot-Bench directory (``DbLv1``-style): task files, their phrasings and scenes, and the cases they make.

Format (LaMPilot's own): one JSON file per task, ``{"commands": [phrasings], "samples": [{"env": {...},
"eval": {...}, "seed": N}]}``; every command goes with every sample. Everything is checked before anything
runs: a file that is not JSON, an unknown ``env.type`` or ``eval.type``, a missing field, each reported with
the file and the field (:class:`LampilotInputError`). The data is the user's: the project ships none of it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ENV_TYPES = ("ramp-merge-v0", "dt-highway-v0", "dt-intersection-v0")
EVAL_FIELDS: dict[str, tuple[tuple[str, ...], ...]] = {
    # eval.type: the alternatives of required fields (one of them must be there)
    "ACCEvalbySpeed": (("speed",), ("rel_speed",)),
    "ACCEvalbyDistance": (("distance",), ("rel_distance",)),
    "LaneChangeEval": (("direction",),),
    "OvertakeEval": (("direction",),),
    "PullOverEval": ((),),
    "IntersectionEval": (("direction",),),
}
GROUPS = {
    "ACCEvalbySpeed": "speed",
    "ACCEvalbyDistance": "following_distance",
    "LaneChangeEval": "lane_change",
    "OvertakeEval": "overtake",
    "PullOverEval": "pull_over",
    "IntersectionEval": "intersection",
}
"""Task groups, by the criterion their tasks are scored by."""
UNSUPPORTED_GROUPS: tuple[str, ...] = ()
"""Groups whose scenes need junctions: listed as not supported, counted as failures in the total."""


class LampilotInputError(ValueError):
    """A LaMPilot directory that cannot be run; lists every problem, each naming its file and field."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


@dataclass(frozen=True)
class Sample:
    index: int
    env: dict[str, Any]
    eval: dict[str, Any]
    seed: int


@dataclass(frozen=True)
class Task:
    name: str
    """The file's stem (``inc_abs_speed28``)."""
    path: Path
    commands: tuple[str, ...]
    samples: tuple[Sample, ...]

    @property
    def group(self) -> str:
        return GROUPS[self.samples[0].eval["type"]]


@dataclass(frozen=True)
class Case:
    """One phrasing of a task on one of its scenes."""

    task: Task
    command_index: int
    sample_index: int

    @property
    def command(self) -> str:
        return self.task.commands[self.command_index]

    @property
    def sample(self) -> Sample:
        return self.task.samples[self.sample_index]

    @property
    def case_id(self) -> str:
        return f"command{self.command_index}-sample{self.sample_index}"


def load_tasks(directory: Path | str, names: list[str] | None = None) -> list[Task]:
    """Every task of ``directory`` (or those named, by file stem), validated; sorted by name."""
    directory = Path(directory)
    if not directory.is_dir():
        raise LampilotInputError([f"{directory}: not a directory of LaMPilot task files (*.json)"])
    files = sorted(directory.glob("*.json"))
    problems: list[str] = []
    if not files:
        problems.append(f"{directory}: no task files (*.json)")
    by_name = {file.stem: file for file in files}
    if names:
        unknown = [name for name in names if name not in by_name]
        if unknown:
            problems.append(f"--tasks: unknown task(s) {', '.join(unknown)}; {directory} has "
                            f"{', '.join(sorted(by_name)) or 'none'}")
        files = [by_name[name] for name in dict.fromkeys(names) if name in by_name]
    tasks = [task for file in files if (task := _load_task(file, problems)) is not None]
    if problems:
        raise LampilotInputError(problems)
    return tasks


def _load_task(file: Path, problems: list[str]) -> Task | None:
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        problems.append(f"{file}: not a JSON file: {error}")
        return None
    found = len(problems)
    if not isinstance(data, dict):
        problems.append(f"{file}: a task file is a JSON object with 'commands' and 'samples'")
        return None
    commands = data.get("commands")
    if not isinstance(commands, list) or not commands or not all(isinstance(c, str) and c.strip() for c in commands):
        problems.append(f"{file}: commands: a non-empty list of phrasings (strings)")
    samples_raw = data.get("samples")
    if not isinstance(samples_raw, list) or not samples_raw:
        problems.append(f"{file}: samples: a non-empty list of {{env, eval, seed}}")
        samples_raw = []
    samples = []
    for i, raw in enumerate(samples_raw):
        where = f"{file}: samples[{i}]"
        if not isinstance(raw, dict):
            problems.append(f"{where}: an object with env, eval and seed")
            continue
        env, evaluation, seed = raw.get("env"), raw.get("eval"), raw.get("seed")
        if not isinstance(env, dict) or env.get("type") not in ENV_TYPES:
            got = env.get("type") if isinstance(env, dict) else env
            problems.append(f"{where}.env.type: unknown scene {got!r}; known: {', '.join(ENV_TYPES)}")
            continue
        if env["type"] != "dt-intersection-v0":
            problems.extend(_env_problems(where, env))
        if not isinstance(evaluation, dict) or evaluation.get("type") not in EVAL_FIELDS:
            got = evaluation.get("type") if isinstance(evaluation, dict) else evaluation
            problems.append(f"{where}.eval.type: unknown criterion {got!r}; known: {', '.join(EVAL_FIELDS)}")
            continue
        alternatives = EVAL_FIELDS[evaluation["type"]]
        if not any(all(key in evaluation for key in keys) for keys in alternatives):
            wanted = " or ".join("+".join(keys) for keys in alternatives)
            problems.append(f"{where}.eval: {evaluation['type']} needs {wanted}")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            problems.append(f"{where}.seed: a non-negative integer, got {seed!r}")
            continue
        samples.append(Sample(i, env, evaluation, seed))
    if samples and len({GROUPS[s.eval["type"]] for s in samples}) > 1:
        problems.append(f"{file}: samples mix criteria of different task groups")
    if len(problems) > found:
        return None
    return Task(file.stem, file, tuple(commands), tuple(samples))


def _env_problems(where: str, env: dict[str, Any]) -> list[str]:
    problems = []
    for key in ("vehicles_count", "vehicles_density"):
        value = env.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float) or value < 0:
            problems.append(f"{where}.env.{key}: a non-negative number, got {value!r}")
    lanes = env.get("num_lanes")
    if lanes is not None and (isinstance(lanes, bool) or not isinstance(lanes, int) or lanes < 2):
        problems.append(f"{where}.env.num_lanes: a whole number of lanes (the emergency lane included), got {lanes!r}")
    ego = env.get("ego_vehicle")
    if not isinstance(ego, dict):
        problems.append(f"{where}.env.ego_vehicle: an object with speed, start_lane_index and start_position")
        return problems
    lane = ego.get("start_lane_index")
    if not (isinstance(lane, list) and len(lane) == 3 and isinstance(lane[2], int) and lane[2] >= 0):
        problems.append(f"{where}.env.ego_vehicle.start_lane_index: [from, to, lane], got {lane!r}")
    position = ego.get("start_position")
    if not (isinstance(position, list) and position and isinstance(position[0], int | float)):
        problems.append(f"{where}.env.ego_vehicle.start_position: [x, y] in metres, got {position!r}")
    speed = ego.get("speed")
    if isinstance(speed, bool) or not isinstance(speed, int | float) or speed < 0:
        problems.append(f"{where}.env.ego_vehicle.speed: a non-negative number (m/s), got {speed!r}")
    return problems


def select_cases(tasks: list[Task], per_task: int | None = None) -> list[Case]:
    """Every (phrasing x scene) of each task, or ``per_task`` of them spread over both in a fixed order:
    case i takes phrasing i mod P and scene i mod S, stepping the scene on when a pair repeats."""
    cases: list[Case] = []
    for task in tasks:
        n_commands, n_samples = len(task.commands), len(task.samples)
        pairs = [(c, s) for s in range(n_samples) for c in range(n_commands)]
        if per_task is None or per_task >= len(pairs):
            chosen = pairs
        else:
            chosen, seen = [], set()
            i = 0
            while len(chosen) < per_task:
                pair = (i % n_commands, (i + i // n_samples) % n_samples) if n_samples else (i % n_commands, 0)
                if pair not in seen:
                    seen.add(pair)
                    chosen.append(pair)
                i += 1
        cases += [Case(task, c, s) for c, s in chosen]
    return cases
