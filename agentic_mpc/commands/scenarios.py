"""``agentic-mpc scenarios``: the scenarios that come with the package, with their descriptions and variants.

Any command that takes a scenario file also takes one of these names (``agentic-mpc run
paper_emergency_response --variant yield``). ``--copy NAME DIR`` copies one into DIR to edit, with the SUMO
network and route files it uses beside it (in ``DIR/sumo_nets/``), so that the copy runs as it is.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("scenarios", help="list the shipped scenarios, or copy one out to edit",
                                   description=__doc__)
    parser.add_argument("--copy", nargs=2, metavar=("NAME", "DIR"), default=None,
                        help="copy the shipped scenario NAME (and the files it names) into DIR")
    parser.add_argument("--paths", action="store_true", help="also print each scenario's file")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc import shipped

    if args.copy is not None:
        name, directory = args.copy
        try:
            written = shipped.copy_scenario(name, Path(directory))
        except (shipped.UnknownScenario, FileExistsError) as error:
            print(f"agentic-mpc scenarios --copy: {error}", file=sys.stderr)
            return 2
        except OSError as error:
            print(f"agentic-mpc scenarios --copy: cannot write {directory}: {error.strerror or error}", file=sys.stderr)
            return 2
        print(f"wrote {written[0]}" + (f" and {len(written) - 1} SUMO file(s) in {written[1].parent}" if written[1:] else ""))
        print(f"run it with: agentic-mpc run {written[0]}")
        return 0
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.worlds import WORLD_KINDS

    for name in shipped.scenario_names():
        loaded = load_scenario(shipped.scenario_path(name))
        world = WORLD_KINDS[loaded.base.world_kind].title
        print(f"{name}  [{world}]  variants: {', '.join(loaded.variant_names)}")
        if loaded.base.description:
            print(f"    {loaded.base.description}")
        if args.paths:
            print(f"    {shipped.scenario_path(name)}")
    return 0
