"""``agentic-mpc batch``: every scenario file x variant x seed, one process per simulation, resumable.

Writes ``DIR/summary.csv`` (one row per run: scenario, variant, seed, status ok|failed|crashed, error, the
run's metrics, scenario_sha256) and each run's files under ``DIR/runs/<scenario>/<variant>/seed-<N>/``.
Run it again with the same arguments to resume: finished runs are skipped, failed and crashed ones are
retried, and runs of a scenario file that has changed since are redone. With ``--executor dask`` the
workers need agentic-mpc and the scenario files (same paths); the run files come back to DIR.
Each run writes its animated replay (replay.html) only with ``--replay``.
Exit status: 0 all runs ok, 1 some run failed or crashed, 2 bad input (nothing ran), 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agentic_mpc.commands import non_negative_int, positive_int, scenario_file

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report Ctrl-C
MAX_LISTED = 20


def _names(text: str) -> list[str]:
    """``--variants a b`` and ``--variants a,b`` both work."""
    return [name for name in text.split(",") if name]


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "batch", help="run scenario files x variants x seeds, one process per run", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("files", nargs="+", type=scenario_file, metavar="FILE",
                        help="scenario YAML files or shipped scenarios' names")
    parser.add_argument("--variants", nargs="+", type=_names, action="extend", metavar="V",
                        help="variants to run in every file (default: each file's variants, or base)")
    parser.add_argument("--trials", type=positive_int, required=True, metavar="N", help="seeds per variant")
    parser.add_argument("--first-seed", type=non_negative_int, default=0, metavar="K",
                        help="seeds are K, K+1, ..., K+N-1 (default 0)")
    parser.add_argument("--workers", type=positive_int, default=None, metavar="W",
                        help="simulations in parallel (default: the cores available)")
    parser.add_argument("--out", type=Path, default=Path("out/batch"), metavar="DIR",
                        help="output directory (default out/batch)")
    parser.add_argument("--executor", choices=("process", "dask"), default="process",
                        help="process: subprocesses here; dask: tasks on a Dask cluster (needs agentic-mpc[dask])")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786")
    parser.add_argument("--runner", metavar="MODULE:FUNCTION", default=None,
                        help="run function f(scenario_file, variant, seed, out_dir) -> summary row "
                             "(default: agentic_mpc.scenario.runner:run_to_directory)")
    parser.add_argument("--replay", action="store_true",
                        help="also write each run's replay.html (agentic-mpc replay); with the default run function")
    parser.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar on stderr")
    parser.set_defaults(handler=run)


def _print_variant_table(summary_path: Path) -> None:
    """The per-variant outcome table (runs from a custom run function may lack its columns)."""
    import pandas as pd

    from agentic_mpc.scenario.report import variant_table

    try:
        table = variant_table(pd.read_csv(summary_path))
    except (KeyError, OSError, pd.errors.EmptyDataError):
        return
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(table.to_string())


REPLAY_RUNNER = "agentic_mpc.scenario.runner:run_to_directory_with_replay"


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.batch import BatchInputError, BatchSpec, default_workers, run_batch

    runner = args.runner
    if args.replay:
        if runner is not None and runner != REPLAY_RUNNER:
            print("agentic-mpc batch: --replay works with the default run function, not --runner", file=sys.stderr)
            return EXIT_BAD_INPUT
        runner = REPLAY_RUNNER
    try:
        spec = BatchSpec(
            files=tuple(args.files), trials=args.trials, first_seed=args.first_seed,
            variants=[v for group in args.variants for v in group] if args.variants else None,
            workers=args.workers or default_workers(), out_dir=args.out, executor=args.executor,
            scheduler=args.scheduler,
        )
        result = run_batch(spec, runner=runner, progress=args.progress)
    except BatchInputError as error:
        print("agentic-mpc batch: nothing was run:\n" + "\n".join(f"  {p}" for p in error.problems), file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:  # while checking the input, before any run started
        return EXIT_INTERRUPTED
    counts = ", ".join(f"{result.count(s)} {s}" for s in ("ok", "failed", "crashed") if result.count(s))
    print(f"{len(result.rows)} of {result.total} runs recorded ({counts or 'none'}); "
          f"{result.ran} ran now, {result.skipped} were already done; wrote {result.summary_path}")
    problems = [row for row in result.rows if row["status"] != "ok"]
    for row in problems[:MAX_LISTED]:
        print(f"  {row['status']}: {row['scenario']}/{row['variant']}/seed-{row['seed']}: {row['error']}")
    if len(problems) > MAX_LISTED:
        print(f"  ... and {len(problems) - MAX_LISTED} more: see {result.summary_path}")
    _print_variant_table(result.summary_path)
    if result.interrupted:
        print("interrupted: run the same command again to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0 if result.all_ok else 1
