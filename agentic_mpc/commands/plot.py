"""``agentic-mpc plot DIR``: figures of a run directory or a batch directory.

A run (DIR has trajectory.csv): its ``trajectory.png`` is redrawn. A batch (DIR has runs/): per scenario,
``<scenario>_trajectories.png`` (every trial over the road, colours by variant; the paper's Figures 3 and
4) and ``<scenario>_timeseries.png`` (speed, offset from the tracked lane, ambulance distance).
The bird's-eye views zoom to where things happen: a thin overview of the road with numbered windows, then a
row of panels per variant around each stopped car, where the ambulance passes the ego, the agent's tool
calls and the ego's lane changes, with the vehicles drawn as their footprints at one moment.
The road comes from the run's saved ``scenario.json`` (SUMO's network, or the plain world); no simulation runs.
"""

from __future__ import annotations

import argparse
import json
import sys
from functools import lru_cache
from pathlib import Path
from typing import Any


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("plot", help="draw the figures of a run or batch directory", description=__doc__)
    parser.add_argument("directory", type=Path, metavar="DIR")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.plots import batch_figures, run_figure

    directory: Path = args.directory
    if (directory / "trajectory.csv").is_file():
        scenario = json.loads((directory / "scenario.json").read_text(encoding="utf-8"))
        title = f"{scenario['name']} / {scenario['variant']} / seed {scenario['seed']}"
        paths = [run_figure(directory, lanes_of(directory / "scenario.json"), recorded_obstacles(directory), title)]
    elif (directory / "runs").is_dir():
        paths = batch_figures(directory, lanes_of)
    else:
        print(f"agentic-mpc plot: {directory} is neither a run (trajectory.csv) nor a batch (runs/)", file=sys.stderr)
        return 2
    for path in paths:
        print(f"wrote {path}")
    return 0


class _Lanes:
    """A lanes source for a road rebuilt without its world."""

    def __init__(self, lanes: Any) -> None:
        self._lanes = lanes

    def lanes(self) -> Any:
        return self._lanes


@lru_cache(maxsize=16)
def _sumo_lanes(net_file: str, road: str | tuple[str, ...]) -> _Lanes:
    from agentic_mpc.sumo.network import RoadNetwork
    from agentic_mpc.world.lanes import RoadLanes

    network = RoadNetwork(net_file)
    sumo_road = network.road(road)
    lanes = {role: sumo_road.lane_paths[i] for role, i in sumo_road.lane_roles().items()}
    limit = min(network.edge(edge_id).getSpeed() for edge_id in sumo_road.edge_ids)
    return _Lanes(RoadLanes(lanes, float(limit), sumo_road.lefthand))


def lanes_of(scenario_json: Path) -> Any | None:
    """A lanes source (``.lanes()``) for the road of the run whose scenario was saved at ``scenario_json``."""
    scenario = json.loads(Path(scenario_json).read_text(encoding="utf-8"))
    if scenario.get("simulation"):
        road = scenario["simulation"]["road"]
        return _sumo_lanes(scenario["simulation"]["net_file"], tuple(road) if isinstance(road, list) else road)
    if scenario.get("plain_world"):
        from agentic_mpc.world.plain import PlainWorld
        from agentic_mpc.world.plain_config import PlainConfig

        return PlainWorld(PlainConfig.model_validate(scenario["plain_world"]))
    return None


def recorded_obstacles(directory: Path) -> Any:
    """The run's obstacle discs read back from ``obstacles.csv``, as the recorder's metrics hold them."""
    import pandas as pd

    from agentic_mpc.primitives import Circle
    from agentic_mpc.scenario.metrics import MetricsRecorder, ObstacleTrack

    metrics = MetricsRecorder()
    if (directory / "obstacles.csv").is_file():
        for obstacle_id, rows in pd.read_csv(directory / "obstacles.csv").groupby("id", dropna=False):
            circles = tuple(Circle(x_m=r.x_m, y_m=r.y_m, radius_m=r.radius_m) for r in rows.itertuples())
            metrics.obstacles.append(ObstacleTrack(str(obstacle_id), circles, float("nan"), 0))
    return metrics
