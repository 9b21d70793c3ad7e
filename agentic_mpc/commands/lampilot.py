"""``agentic-mpc lampilot DIR --out OUT``: LaMPilot-Bench in closed loop in SUMO, scored by its own criteria.

Runs every (phrasing x scene) of the chosen tasks of a LaMPilot-format directory (``DIR/*.json``, e.g. the
benchmark's ``DbLv1``) as a resumable batch, one process per case, with any agent backend. Writes
``OUT/cases.csv`` (one row per case: task, group, command, seed, success, collided, score, reason, the run's
directory), ``OUT/table.csv`` (completion %, collision %, mean driving score per task group and in total),
``OUT/summary.csv`` (the batch's rows: every run metric) and each case's run files under ``OUT/runs/``.
Run it again to resume. Intersection tasks are listed as not supported and count as failures.

Examples:
    agentic-mpc lampilot ../LaMPilot/DbLv1 --out out/lampilot
    agentic-mpc lampilot DbLv1 --tasks left_lc pull_over --per-task 5 --out out/lp-small
    agentic-mpc lampilot DbLv1 --per-task 3 --backend llamacpp --model-path qwen.gguf --threads 1 --out out/lp-qwen

Exit status: 0 every case ran (whatever it scored), 1 some run failed or crashed, 2 bad input (nothing ran),
130 interrupted.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import sys
from pathlib import Path

from agentic_mpc.commands import (
    CommandInputError,
    add_backend_flags,
    agent_setting,
    flag_settings,
    positive_int,
    validated_agent_settings,
)

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
RUNNER = "agentic_mpc.lampilot.runner:run_case"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("lampilot", help="LaMPilot-Bench in closed loop in SUMO", description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("directory", type=Path, metavar="DIR", help="a LaMPilot-format directory of task files")
    parser.add_argument("--out", type=Path, required=True, metavar="OUT", help="output directory")
    parser.add_argument("--tasks", nargs="+", default=None, metavar="NAME", help="task file stems (default: all)")
    parser.add_argument("--per-task", type=positive_int, default=None, metavar="N",
                        help="N cases of each task, spread over its phrasings and scenes in a fixed order")
    parser.add_argument("--phrasings", type=Path, default=None, metavar="FILE",
                        help="a YAML mapping of task names to lists of your own phrasings: those tasks only, each "
                             "with these commands instead of the file's (the scenes stay the benchmark's)")
    parser.add_argument("--scenes", type=positive_int, default=None, metavar="N",
                        help="only the first N scenes (samples) of each task")
    parser.add_argument("--speed-requests", choices=("lawful", "as_asked"), default="lawful",
                        help="lawful: speeds up to the road's limit (31.29 m/s), the agent says why it keeps to it; "
                             "as_asked: up to the vehicle's top speed (40 m/s), as LaMPilot's highway-env allows")
    add_backend_flags(parser)
    parser.add_argument("--agent", type=agent_setting, action="append", default=[], metavar="KEY=VALUE",
                        help="any agent setting (as a scenario's agent:), e.g. mode=realtime or latency_s=1")
    parser.add_argument("--workers", type=positive_int, default=None, metavar="W",
                        help="cases in parallel (default: the cores available)")
    parser.add_argument("--executor", choices=("process", "dask"), default="process",
                        help="process: subprocesses here; dask: tasks on a Dask cluster (needs agentic-mpc[dask])")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786")
    parser.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar on stderr")
    parser.set_defaults(handler=run)


def agent_for(args: argparse.Namespace) -> dict:
    """The agent's settings of every case: the backend flags, then ``--agent`` pairs (lockstep by default)."""
    import yaml

    settings = flag_settings(args)
    validated_agent_settings(settings)  # a bad flag is named as the flag
    for key, value in args.agent:
        settings[key] = yaml.safe_load(value) if value.strip() else ""
    validated = validated_agent_settings(settings, "--agent ")
    if "toolset" in type(validated).model_fields and "toolset" not in settings:
        settings["toolset"] = "lampilot"  # a model is shown LaMPilot's manoeuvres, not only the paper's tools
        validated = validated_agent_settings(settings, "--agent ")
    return validated.model_dump(mode="json")


def with_phrasings(tasks: list, path: Path) -> list:
    """The tasks named in the phrasings file ``path`` (YAML: task name -> list of phrasings), each with those
    phrasings as its commands. Raises CommandInputError naming the file and the entry."""
    import yaml

    try:
        phrasings = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as error:
        raise CommandInputError(f"--phrasings {path}: cannot read it: {error}") from error
    if not isinstance(phrasings, dict):
        raise CommandInputError(f"--phrasings {path}: a mapping of task names to lists of phrasings")
    known = {task.name: task for task in tasks}
    problems = [f"--phrasings {path}: {name!r}: " + ("no such task in the directory" if name not in known else
                "a non-empty list of phrasings (strings)")
                for name, commands in phrasings.items()
                if name not in known or not isinstance(commands, list) or not commands
                or not all(isinstance(c, str) and c.strip() for c in commands)]
    if problems:
        raise CommandInputError("; ".join(problems))
    return [dataclasses.replace(known[name], commands=tuple(commands)) for name, commands in phrasings.items()]


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.batch import BatchInputError, BatchSpec, default_workers, run_batch
    from agentic_mpc.batch.planning import BatchJob
    from agentic_mpc.lampilot.dataset import UNSUPPORTED_GROUPS, LampilotInputError, load_tasks, select_cases
    from agentic_mpc.lampilot.report import PUBLISHED, case_rows, write_outputs
    from agentic_mpc.lampilot.runner import write_case
    from agentic_mpc.lampilot.scenes import scene_problem

    try:
        agent = agent_for(args)
        tasks = load_tasks(args.directory, args.tasks)
        if args.phrasings is not None:
            tasks = with_phrasings(tasks, args.phrasings)
        if args.scenes is not None:
            tasks = [dataclasses.replace(task, samples=task.samples[: args.scenes]) for task in tasks]
    except (ValueError, CommandInputError) as error:
        problems = error.problems if isinstance(error, LampilotInputError) else [str(error)]
        print("agentic-mpc lampilot: nothing was run:\n" + "\n".join(f"  {p}" for p in problems), file=sys.stderr)
        return EXIT_BAD_INPUT
    cases = select_cases(tasks, args.per_task)
    jobs, unsupported = [], []
    for case in cases:
        problem = scene_problem(case.sample.env)
        if case.task.group in UNSUPPORTED_GROUPS or problem is not None:  # counted as a failure, the rest run
            unsupported.append({"task": case.task.name, "group": case.task.group, "case": case.case_id,
                                "command": case.command, "seed": case.sample.seed, "status": "not run",
                                "success": False, "collided": False, "score": 0.0,
                                "reason": problem or "not supported by this version"})
            continue
        case_file = args.out / "cases" / case.task.name / f"{case.case_id}.json"
        write_case(case, agent, case_file, args.speed_requests)
        digest = hashlib.sha256(case_file.read_bytes()).hexdigest()[:16]
        jobs.append(BatchJob(case.task.name, case.case_id, case.sample.seed, case_file.resolve(), digest))
    try:
        spec = BatchSpec(files=tuple(job.scenario_file for job in jobs) or (args.directory,), trials=1,
                         workers=args.workers or default_workers(), out_dir=args.out, executor=args.executor,
                         scheduler=args.scheduler)
        result = run_batch(spec, runner=RUNNER, progress=args.progress, jobs=jobs)
    except BatchInputError as error:
        print("agentic-mpc lampilot: nothing was run:\n" + "\n".join(f"  {p}" for p in error.problems), file=sys.stderr)
        return EXIT_BAD_INPUT
    rows = case_rows(result.rows, args.out, unsupported)
    cases_path, table_path, table = write_outputs(rows, args.out)
    import pandas as pd

    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.to_string())
    print(f"LaMPilot's published figures (GPT-4 with human feedback): {PUBLISHED['completion_pct']} % completion, "
          f"{PUBLISHED['collision_pct']} % collisions")
    print(f"{len(rows)} cases ({result.ran} ran now, {result.skipped} were already done); wrote {cases_path} and "
          f"{table_path}")
    if result.interrupted:
        print("interrupted: run the same command again to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0 if all(row["status"] == "ok" for row in result.rows) else 1
