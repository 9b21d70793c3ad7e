"""``agentic-mpc plot DIR``: figures of a run directory or a batch directory.

A run (DIR has trajectory.csv): its ``trajectory.png`` is redrawn. A batch (DIR has runs/): per scenario,
``<scenario>_trajectories.png`` (every trial over the road, colours by variant; the paper's Figures 3 and
4) and ``<scenario>_timeseries.png`` (speed, offset from the tracked lane, ambulance distance).
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
    from agentic_mpc.scenario.plots import batch_figures, run_figure
    from agentic_mpc.scenario.replay import RecordedRun, road_of

    directory: Path = args.directory
    if (directory / "trajectory.csv").is_file():
        recorded = RecordedRun(directory)
        paths = [run_figure(directory, recorded.road, recorded, title=recorded.title)]
    elif (directory / "runs").is_dir():
        paths = batch_figures(directory, road_of)
    else:
        print(f"agentic-mpc plot: {directory} is neither a run (trajectory.csv) nor a batch (runs/)", file=sys.stderr)
        return 2
    for path in paths:
        print(f"wrote {path}")
    return 0
