"""``agentic-mpc check FILE...``: validate scenario files (every variant) without simulating.

Every problem is reported with its file, line and YAML path; the exit code is 0 when all files are valid,
2 otherwise.
"""

from __future__ import annotations

import argparse
import sys

from agentic_mpc.commands import scenario_file


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("check", help="validate scenario files", description=__doc__)
    parser.add_argument("files", nargs="+", type=scenario_file, metavar="FILE",
                        help="scenario YAML files or shipped scenarios' names")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.scenario.yaml_source import ScenarioFileError

    failed = False
    for file in args.files:
        try:
            loaded = load_scenario(file)
        except ScenarioFileError as error:
            failed = True
            print(error, file=sys.stderr)
            continue
        print(f"{file}: ok ({loaded.base.name}; variants: {', '.join(loaded.variant_names)})")
    return 2 if failed else 0
