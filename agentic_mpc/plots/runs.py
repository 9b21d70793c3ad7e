"""A run as the figures see it: its tables (through the one reader, :mod:`agentic_mpc.run.reader`), the ego's
place along the road at every step, and the road it drove on."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from agentic_mpc.plots.road import run_road
from agentic_mpc.run.files import EVENTS, SIGNALS, TRAFFIC, TRAJECTORY
from agentic_mpc.run.reader import Obstacle, RunDirectory, is_emergency, read_run

NETWORK_MARGIN_M = 60.0
"""How far around the ego's paths the figures draw the network (the panels reach a few tens of metres across)."""


@dataclass
class PlottedRun:
    """What the figures need of one run; ``trajectory`` has an ``s`` column (the ego's road s) and only the
    steps with a position, ``traffic``'s ``emergency`` says whether each is an emergency vehicle."""

    directory: RunDirectory
    name: str
    variant: str
    trajectory: pd.DataFrame
    traffic: pd.DataFrame
    events: pd.DataFrame
    obstacles: list[Obstacle]
    signals: pd.DataFrame = field(default_factory=pd.DataFrame)
    """``signals.csv``: the traffic lights the route met (empty without)."""

    def size_of(self, vehicle_id: str, type_id: str, vclass: str) -> tuple[float, float]:
        """(length, width) of a traffic vehicle, as the replay finds it."""
        return self.directory.size_of(vehicle_id, type_id, vclass)

    @property
    def ego_size(self) -> tuple[float, float]:
        return self.directory.ego_size

    @cached_property
    def road(self) -> Any:
        """The road rebuilt from the run's ``scenario.json`` (a lanes source), None without one."""
        return run_road(self.directory.scenario)

    def obstacle_shapes(self) -> list[tuple[Any, Any]]:
        """(discs, stopped car) of each obstacle, for :func:`~agentic_mpc.plots.drawing.draw_obstacles`."""
        return [(o.discs, o.car(self.directory.sizes)) for o in self.obstacles]

    def lights_at(self, t: float) -> list[tuple[float, float, float, str]]:
        """(x, y, heading, state) of each stop line's light as the ego saw it at time ``t`` (its last change)."""
        if self.signals.empty:
            return []
        before = self.signals[self.signals["time_s"] <= t + 1e-9]
        latest = before.groupby("junction_id", sort=False).tail(1)
        return [(float(r.x_m), float(r.y_m), float(r.heading_rad), str(r.state)) for r in latest.itertuples()]

    def ego_at(self, t: float) -> tuple[float, float, float]:
        """The ego's (x, y, heading) at time ``t`` (the nearest recorded step)."""
        i = int(np.clip(np.searchsorted(self.trajectory["time_s"].to_numpy(), t), 0, len(self.trajectory) - 1))
        row = self.trajectory.iloc[i]
        return float(row["x_m"]), float(row["y_m"]), float(row.get("phi_rad", 0.0))

    def time_at_s(self, s: float) -> float | None:
        """The first time the ego reached road position ``s``, None if it never did."""
        reached = np.flatnonzero(self.trajectory["s"].to_numpy() >= s)
        return float(self.trajectory["time_s"].iloc[reached[0]]) if reached.size else None


def plotted_run(directory: Path, obstacles: list[Obstacle] | None = None, variant: str = "") -> PlottedRun:
    """The run in ``directory`` (its obstacles: ``obstacles`` if given, else ``obstacles.csv``'s; its variant:
    ``variant`` if given, else its scenario's)."""
    run = read_run(directory)
    trajectory = run.table(TRAJECTORY)
    trajectory = trajectory[np.isfinite(trajectory["x_m"]) & np.isfinite(trajectory["y_m"])].reset_index(drop=True)
    if "road_s_m" in trajectory and trajectory["road_s_m"].notna().all():
        trajectory["s"] = trajectory["road_s_m"].to_numpy(dtype=float)
    else:  # no road position recorded: the distance driven
        steps = np.hypot(np.diff(trajectory["x_m"]), np.diff(trajectory["y_m"]))
        trajectory["s"] = np.concatenate([[0.0], np.cumsum(steps)])
    traffic = run.table(TRAFFIC)
    if not traffic.empty:
        traffic["emergency"] = [is_emergency(flag, vclass) for flag, vclass in zip(traffic["emergency"],
                                                                                   traffic["vclass"])]
    signals = run.table(SIGNALS)
    if not signals.empty:
        signals = signals.sort_values("time_s", kind="stable").reset_index(drop=True)
    return PlottedRun(run, str(run.path), variant or str(run.scenario.get("variant", "")), trajectory, traffic,
                      run.table(EVENTS), run.obstacles if obstacles is None else obstacles, signals)


def network_of(runs: list[PlottedRun], margin_m: float = NETWORK_MARGIN_M) -> Any:
    """The SUMO network around ``runs``' paths (one road; :mod:`agentic_mpc.plots.network`), None where there is
    none to draw beside the road (a plain world, the paper's roads) or the network file cannot be read."""
    simulation = runs[0].directory.scenario.get("simulation") if runs else None
    if not simulation:
        return None
    from agentic_mpc.plots.network import corridor, sumo_network_near

    paths = [run.trajectory[["x_m", "y_m"]].to_numpy(dtype=float) for run in runs]
    try:
        network = sumo_network_near(simulation, corridor(paths, margin_m))
    except (OSError, ValueError, KeyError) as error:  # the figure without the network beats no figure
        runs[0].directory.notes.append(f"network not drawn: {error}")
        return None
    return network or None
