"""``agentic-mpc eval-agent``: how well a backend turns passenger messages into the right tool calls.

Runs the evaluation suite (default: the shipped ``agentic_mpc/agent_eval/suite.yaml``, 101 cases: sides,
negations, speeds with units and vague ones, lane changes, yielding to an emergency vehicle on left- and
right-hand roads, resuming, undoing, compound requests, questions and small talk that need no call,
German, Japanese, Spanish and French). Each case goes to a fresh agent over its world at the start (the
plain-Python worlds, built once and reset between cases); every turn is scored against the calls it
expects (order-insensitive; a missing or extra call is wrong; a turn that expects none is wrong if any call
was tried). Prints accuracy by category, unparsed and invalid calls, latency p50/p95; ``--out DIR`` writes
``turns.csv``, ``cases.json``, ``summary.json`` and ``categories.csv``::

    agentic-mpc eval-agent                                   # the rules backend (not a language model)
    agentic-mpc eval-agent --backend llamacpp --model-path model.gguf --threads 1 --out out/eval
    agentic-mpc eval-agent --backend openai --base-url http://localhost:11434/v1 --model granite4:micro
    agentic-mpc eval-agent --category yield --limit 5
    agentic-mpc eval-agent --backend llamacpp --model-path model.gguf --closed-loop --seeds 2

``--closed-loop`` runs the paper's scenarios instead (SUMO: Scenario 1 asking for the left and the right
side, Scenario 2 yielding to the ambulance, plus Scenario 2 without a message as the baseline) with that
backend, and reports the side the obstacle was passed on, collisions, the ambulance's delay and the calls.

Exit status: 0 when the suite ran (whatever the accuracy); 2 for bad input (a malformed suite file, an
option that does not apply to the backend, a missing or non-GGUF model file, xllamacpp not installed).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path

from agentic_mpc.commands import add_backend_flags, non_negative_int, positive_int

PROG = "agentic-mpc eval-agent"
_ONLY_FOR = {"model_path": ("llamacpp",), "threads": ("llamacpp",), "ctx_size": ("llamacpp",),
             "base_url": ("openai",), "model": ("openai",), "api_key_env": ("openai",), "extra_body": ("openai",),
             **{name: ("openai", "llamacpp") for name in ("tool_mode", "temperature", "max_tokens", "timeout_s",
                                                         "confirmation", "extra_prompt")},
             "yield_lane": ("rules",), "rules_first": ("openai", "llamacpp")}


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "eval-agent", help="score a backend's tool calls on the evaluation suite", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--suite", type=Path, default=None, help="the suite YAML (default: the shipped one)")
    add_backend_flags(parser)
    parser.add_argument("--max-rounds", type=positive_int, default=None,
                        help="backend answers per turn (default 2: a call and a second one; json_schema mode "
                             "allows one call per answer, so a compound request needs both); with --closed-loop "
                             "the scenarios' max_rounds_per_step (default theirs, 6)")
    parser.add_argument("--category", action="append", default=None, help="only this category (repeatable)")
    parser.add_argument("--case", action="append", default=None, help="only this case id (repeatable)")
    parser.add_argument("--per-category", type=positive_int, default=None,
                        help="only the first N cases of each category (a quick sample for slow models)")
    parser.add_argument("--limit", type=non_negative_int, default=None, help="only the first N selected cases")
    parser.add_argument("--out", type=Path, default=None, help="write turns.csv, cases.json, summary.json here")
    parser.add_argument("--quiet", action="store_true", help="no line per case")
    parser.add_argument("--closed-loop", action="store_true",
                        help="run the paper's scenarios (SUMO) with this backend instead of the suite")
    parser.add_argument("--seeds", type=positive_int, default=1, help="--closed-loop: seeds per scenario (1)")
    parser.set_defaults(handler=run)


class InputError(ValueError):
    """Bad input: said in one line, exit status 2."""


def _check_options(args: argparse.Namespace) -> None:
    for name, backends in _ONLY_FOR.items():
        if getattr(args, name) not in (None, False) and args.backend not in backends:
            raise InputError(f"--{name.replace('_', '-')} applies to --backend {' or '.join(backends)}, "
                             f"not {args.backend}")
    if args.backend == "llamacpp" and args.model_path is None:
        raise InputError("--backend llamacpp needs --model-path (a GGUF model file)")
    if args.closed_loop and (args.category or args.case or args.limit is not None or args.suite or args.per_category):
        raise InputError("--closed-loop runs the paper's scenarios: --suite, --category, --case, --limit, "
                         "--per-category do not apply")


def _settings(args: argparse.Namespace):  # -> AgentSettings
    """The flags as the agent's settings, validated (agent/settings.py): a bad one is one line, exit 2."""
    from agentic_mpc.commands import flag_settings, validated_agent_settings

    try:
        settings = flag_settings(args)
        if args.max_rounds is not None:
            settings["max_rounds_per_step"] = args.max_rounds
        return validated_agent_settings(settings)
    except ValueError as error:
        raise InputError(f"the {args.backend} backend could not be set up: {error}") from None


def _agent_settings(args: argparse.Namespace) -> list[tuple[str, str]]:
    """The flags as ``--agent KEY=VALUE`` pairs for the scenarios' ``agent:`` (``--closed-loop``)."""
    given = _settings(args).model_dump(exclude_defaults=True)
    given["backend"] = args.backend
    return [(key, json.dumps(value) if isinstance(value, dict) else str(value)) for key, value in given.items()]


def _fail(message: str, status: int = 2) -> int:
    print(f"{PROG}: {message}", file=sys.stderr)
    return status


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(level=logging.ERROR, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s")
    try:
        _check_options(args)
        if args.closed_loop:
            return _closed_loop(args)
        return _suite(args)
    except InputError as error:
        return _fail(str(error))


def _closed_loop(args: argparse.Namespace) -> int:
    from agentic_mpc.agent_eval.closed_loop import COLUMNS, SCENARIO_1, closed_loop_table, run_closed_loop
    from agentic_mpc.agent_eval.report import write_rows
    from agentic_mpc.commands import with_agent_settings
    from agentic_mpc.scenario.schema import load_scenario

    if args.backend == "llamacpp":  # before any simulation: a bad model file is said at once
        from agentic_mpc.agent.backends.llamacpp import check_gguf

        try:
            check_gguf(args.model_path)
        except ValueError as error:
            return _fail(f"the llamacpp backend could not be set up: {error}")
    out_dir = args.out or Path("out") / "eval-agent-closed-loop"
    pairs = _agent_settings(args)
    try:
        with_agent_settings(load_scenario(SCENARIO_1).variant(None), pairs)  # a bad setting is said before any run
    except ValueError as error:
        return _fail(str(error))
    try:
        rows = run_closed_loop(lambda scenario: with_agent_settings(scenario, pairs), args.seeds, out_dir,
                               progress=None if args.quiet else lambda row: print(
                                   f"{row['scenario']} / {row['variant']} / seed {row['seed']}: {row['status']}",
                                   file=sys.stderr, flush=True))
    except ValueError as error:
        return _fail(str(error))
    print(closed_loop_table(rows))
    write_rows(out_dir / "closed_loop.csv", rows, COLUMNS)
    print(f"wrote {out_dir / 'closed_loop.csv'}")
    return 0


def _suite(args: argparse.Namespace) -> int:
    from agentic_mpc.agent.backends import make_backend
    from agentic_mpc.agent_eval.report import summarise, table, turn_row, write
    from agentic_mpc.agent_eval.runner import KeepOpen, run_suite, suite_agent_config
    from agentic_mpc.agent_eval.suite import SuiteError, load_suite
    from agentic_mpc.scenario.yaml_source import ScenarioFileError
    from agentic_mpc.world.base import WorldError

    try:
        suite = load_suite(args.suite)
        cases = suite.select(args.category, args.case, args.limit, args.per_category)
    except SuiteError as error:
        return _fail(str(error))
    model = None
    settings = _settings(args)
    rules_first = bool(getattr(settings, "rules_first", False))
    bare = settings.model_copy(update={"rules_first": False}) if rules_first else settings  # wrapped per case below
    if args.backend != "rules":
        try:  # llamacpp: loaded once for the whole suite, each case's agent borrows it; openai: options checked
            model = bare.build_backend(lefthand=True)
        except (ValueError, ImportError) as error:
            return _fail(f"the {args.backend} backend could not be set up: {error}")

    def backend_for(lefthand: bool):  # -> Backend
        rules = make_backend("rules", lefthand=lefthand, **({"yield_lane": args.yield_lane} if args.yield_lane else {}))
        if args.backend == "llamacpp":
            chosen = KeepOpen(model)
        elif args.backend == "openai":  # its HTTP client belongs to one event loop: one backend per agent
            chosen = bare.build_backend(lefthand)
        else:
            return rules
        if rules_first:
            from agentic_mpc.agent.backends.rules_first import RulesFirst

            return RulesFirst(rules, chosen)
        return chosen

    partial = None
    if args.out is not None:  # a slow model's results so far survive an interrupted run
        args.out.mkdir(parents=True, exist_ok=True)
        partial = args.out / "turns.partial.jsonl"
        partial.write_text("", encoding="utf-8")

    def progress(result, done: int, total: int) -> None:
        if partial is not None:
            with partial.open("a", encoding="utf-8") as file:
                for turn in result.turns:
                    file.write(json.dumps(turn_row(turn) | {"unparsed": turn.unparsed, "invalid": turn.invalid},
                                          ensure_ascii=False) + "\n")
        if args.quiet:
            return
        mark = "right" if result.right else "WRONG"
        wrong = next((t for t in result.turns if not t.right), None)
        why = f"  turn {wrong.turn}: {wrong.detail}" if wrong is not None else ""
        seconds = sum(t.latency_s for t in result.turns)
        model_s = [t.model_s for t in result.turns if t.model_s is not None]
        own = f" (model {sum(model_s):.1f} s)" if model_s else ""
        print(f"[{done:3}/{total}] {mark:5} {seconds:6.1f} s{own}  {result.case.id}{why}", file=sys.stderr, flush=True)

    config = suite_agent_config(settings.model_copy(update={"max_rounds_per_step": args.max_rounds or 2}))
    started = time.perf_counter()
    try:
        results = run_suite(suite, cases, backend_for, config, progress)
    except (SuiteError, ScenarioFileError) as error:  # a suite whose world's scenario file is broken
        return _fail(str(error))
    except WorldError as error:
        return _fail(f"a world of the suite could not start: {error}", status=1)
    finally:
        if args.backend == "llamacpp":
            model.close()
    about = {"backend": ("rules+" if rules_first else "") + args.backend,
             "model": str(args.model_path or args.model or ""),
             "tool_mode": getattr(settings, "effective_tool_mode", ""),
             "threads": args.threads, "max_tokens": args.max_tokens, "max_rounds": config.max_rounds_per_step,
             "suite": str(suite.path), "wall_s": round(time.perf_counter() - started, 1)}
    summary = summarise(results, suite.categories, about)
    print(table(summary))
    if args.out is not None:
        paths = write(args.out, results, summary)
        print(f"wrote {', '.join(str(p) for p in paths)}")
    return 0
