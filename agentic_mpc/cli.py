"""The ``agentic-mpc`` command line. Each subcommand lives in ``agentic_mpc/commands/<name>.py`` and exposes
``register(subparsers)``; heavy imports happen inside the commands so ``--help`` stays instant."""

from __future__ import annotations

import argparse
import importlib
import os
import sys

COMMANDS = ("run", "batch", "check", "scenarios", "plot", "replay", "demo", "ask", "eval_agent", "serve", "bench",
            "lampilot", "knowledge_server")
"""Command modules under agentic_mpc.commands, in the order ``--help`` lists them."""


def _pin_blas_threads() -> None:
    # The controller's matrix products are tiny; multithreaded BLAS on them was 5-30x slower on 2 cores.
    for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, "1")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="agentic-mpc",
        description="Agentic MPC: an agent rewrites a Fourier MPPI controller's specification while the car drives.",
    )
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"agentic_mpc.commands.{name}").register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    _pin_blas_threads()
    args = build_parser().parse_args(argv)
    return int(args.handler(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
