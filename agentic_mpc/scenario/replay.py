"""Rebuild what a figure needs from a finished run directory (no SUMO): the road and the obstacles."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

import pandas as pd

from agentic_mpc.primitives import Circle
from agentic_mpc.scenario.metrics import ObstacleTrack
from agentic_mpc.sumo.network import RoadNetwork


@lru_cache(maxsize=16)
def _road(net_file: str, road: str | tuple[str, ...]) -> Any:
    return RoadNetwork(net_file).road(road)


def road_of(scenario_json: Path) -> Any:
    """The road of the run whose validated scenario was saved at ``scenario_json``."""
    simulation = json.loads(Path(scenario_json).read_text(encoding="utf-8"))["simulation"]
    road = simulation["road"]
    return _road(simulation["net_file"], tuple(road) if isinstance(road, list) else road)


class RecordedRun:
    """A run directory read back: its road, obstacle discs and title."""

    def __init__(self, directory: Path) -> None:
        self.directory = Path(directory)
        scenario = json.loads((self.directory / "scenario.json").read_text(encoding="utf-8"))
        self.road = road_of(self.directory / "scenario.json")
        self.title = f"{scenario['name']} / {scenario['variant']} / seed {scenario['seed']}"
        self.obstacles: list[ObstacleTrack] = []
        obstacles_file = self.directory / "obstacles.csv"
        if obstacles_file.is_file():
            table = pd.read_csv(obstacles_file)
            for obstacle_id, rows in table.groupby("id"):
                circles = tuple(Circle(x_m=r.x_m, y_m=r.y_m, radius_m=r.radius_m) for r in rows.itertuples())
                self.obstacles.append(ObstacleTrack(str(obstacle_id), circles, float("nan"), 0))
