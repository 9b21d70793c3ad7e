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
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("plot", help="draw the figures of a run or batch directory", description=__doc__)
    parser.add_argument("directory", type=Path, metavar="DIR")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.run.files import TRAJECTORY

    directory: Path = args.directory
    if (directory / TRAJECTORY).is_file():
        from agentic_mpc.plots.figures import run_figure
        from agentic_mpc.run.reader import read_run

        scenario = read_run(directory).scenario
        title = f"{scenario['name']} / {scenario['variant']} / seed {scenario['seed']}" if scenario else directory.name
        paths = [run_figure(directory, title=title)]
    elif (directory / "runs").is_dir():
        from agentic_mpc.plots.figures import batch_figures

        paths = batch_figures(directory)
    else:
        print(f"agentic-mpc plot: {directory} is neither a run (trajectory.csv) nor a batch (runs/)", file=sys.stderr)
        return 2
    for path in paths:
        print(f"wrote {path}")
    return 0
