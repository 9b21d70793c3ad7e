"""Task files in LaMPilot's format, written by the tests (our phrasings and scenes: no LaMPilot data here)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def motorway_env(count: int = 6, density: float = 0.3, lane: int = 1, speed: float = 25.0) -> dict[str, Any]:
    return {"type": "ramp-merge-v0", "vehicles_count": count, "vehicles_density": density,
            "stage_length": [500, 80, 80, 2000],
            "ego_vehicle": {"speed": speed, "start_lane_index": ["c", "d", lane], "start_position": [105, 0]}}


def shoulder_env(lanes: int = 3, count: int = 4, density: float = 0.2) -> dict[str, Any]:
    return {"type": "dt-highway-v0", "vehicles_count": count, "num_lanes": lanes, "vehicles_density": density,
            "stage_length": [2000],
            "ego_vehicle": {"speed": 25, "start_lane_index": ["a", "b", 1], "start_position": [105, 0]}}


TASKS: dict[str, tuple[list[str], dict[str, Any], dict[str, Any]]] = {
    # name: (phrasings, env, eval)
    "speed_abs": (["Hold 20 metres per second, please."], motorway_env(), {"type": "ACCEvalbySpeed", "speed": 20}),
    "speed_rel": (["Slow down by 5 m/s."], motorway_env(), {"type": "ACCEvalbySpeed", "rel_speed": -5}),
    "gap_abs": (["Keep a following distance of 40 metres."], motorway_env(), {"type": "ACCEvalbyDistance", "distance": 40}),
    "lane_left": (["Please change to the left lane."], motorway_env(), {"type": "LaneChangeEval", "direction": "left"}),
    # a car to pass and nothing that blocks the passing lane at its speed (at density 0.9 a car there did, once
    # the ego entered at the speed SUMO's leader had, not the one predicted for it)
    "pass_left": (["Pass the car ahead in the left lane."], motorway_env(speed=31.29, density=0.5, count=3),
                  {"type": "OvertakeEval", "direction": "left"}),
    "shoulder": (["Pull onto the hard shoulder and stop."], shoulder_env(), {"type": "PullOverEval"}),
}


def write_tasks(directory: Path, names: list[str] | None = None, seed: int = 7) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    for name, (commands, env, evaluation) in TASKS.items():
        if names is None or name in names:
            sample = {"env": env, "eval": evaluation, "seed": seed}
            (directory / f"{name}.json").write_text(json.dumps({"commands": commands, "samples": [sample]}))
    return directory
