"""Memory across runs, measured: the dialogues of ``memory_dialogues.yaml`` with memory and without.

``python -m agentic_mpc.agent_eval.memory_eval [--agent KEY=VALUE ...] [--json OUT.json]``

Each dialogue is two runs of one passenger profile (a fresh memory file in a temporary directory): run 1's
messages, then run 2's in a new run (a new world, MCP server and agent; the memory file is what connects
them). A message is right when the calls the agent made (accepted or refused by the server: the decision is
scored, not the world) are exactly its ``expect``. Reported: run 2 right with memory and without (the same
messages, no ``memory:``), and run 1's own expectations (the corrections answered in the run) both ways.

The rules backend is the default; ``--agent backend=openai --agent base_url=... --agent model=...`` scores a
language model the same way (it gets the memory as context lines beside the situation: agent/memory_recall.py).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

DIALOGUES = Path(__file__).with_name("memory_dialogues.yaml")
TOLERANCE = 0.05


@dataclass
class Said:
    text: str
    expect: list[dict[str, Any]] | None = None


@dataclass
class Dialogue:
    id: str
    about: str
    run1: list[Said]
    run2: list[Said]


@dataclass
class Outcome:
    dialogue: str
    run: int
    memory: bool
    text: str
    expected: list[dict[str, Any]]
    made: list[dict[str, Any]]
    right: bool
    reply: str = ""
    notes: list[str] = field(default_factory=list)


def load_dialogues(path: Path = DIALOGUES) -> tuple[str, list[Dialogue]]:
    """(the scenario, the dialogues) of a dialogue file."""
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    if not isinstance(data, dict) or data.get("version") != 1:
        raise ValueError(f"{path}: expected a mapping with version: 1")

    def said(item: Any) -> Said:
        return Said(item) if isinstance(item, str) else Said(item["say"], item.get("expect"))

    dialogues = [Dialogue(d["id"], d.get("about", ""), [said(x) for x in d["run1"]], [said(x) for x in d["run2"]])
                 for d in data["dialogues"]]
    return data.get("scenario", "paper_steering_preference_plain"), dialogues


def same_calls(made: list[dict[str, Any]], expected: list[dict[str, Any]]) -> bool:
    """Whether ``made`` are ``expected`` (order aside; numbers within :data:`TOLERANCE`)."""
    def close(a: Any, b: Any) -> bool:
        if isinstance(a, int | float) and isinstance(b, int | float) and not isinstance(a, bool):
            return math.isclose(float(a), float(b), abs_tol=TOLERANCE)
        return a == b

    def match(a: dict[str, Any], b: dict[str, Any]) -> bool:
        args_a, args_b = a.get("arguments") or {}, b.get("arguments") or {}
        return str(a["tool"]) == str(b["tool"]) and set(args_a) == set(args_b) and all(
            close(args_a[k], args_b[k]) for k in args_a)

    left = list(expected)
    for call in made:
        found = next((e for e in left if match(call, e)), None)
        if found is None:
            return False
        left.remove(found)
    return not left


def _run(scenario: Any, settings: dict[str, Any], messages: list[Said], dialogue: str, run: int,
         memory: bool) -> list[Outcome]:
    from agentic_mpc.agent.settings import agent_settings
    from agentic_mpc.run.loop import AgentSetup
    from agentic_mpc.scenario.runner import build_loop, build_world

    world = build_world(scenario)
    chosen = agent_settings(settings)
    setup = AgentSetup(chosen.build_backend(world.lanes().lefthand),
                       chosen.agent_config(backend_attempts=2, retry_backoff_s=0.2))
    outcomes = []
    with build_loop(scenario, world, agent=setup) as loop:
        for said in messages:
            report = loop.agent.deliver(said.text).result()
            made = [{"tool": str(c["tool"]), "arguments": c["arguments"]} for c in report.tool_calls]
            right = said.expect is not None and same_calls(made, said.expect)
            outcomes.append(Outcome(dialogue, run, memory, said.text, said.expect or [], made, right, report.text))
    return outcomes


def evaluate(settings: dict[str, Any] | None = None, path: Path = DIALOGUES,
             only: set[str] | None = None) -> list[Outcome]:
    """Every dialogue of ``path`` with memory and without; the scored messages (those with ``expect``)."""
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.shipped import scenarios_dir

    name, dialogues = load_dialogues(path)
    scenario = load_scenario(scenarios_dir() / f"{name}.yaml").variant(None)
    base = {"backend": "rules", "mode": "realtime", "knowledge": False, **(settings or {})}
    outcomes: list[Outcome] = []
    for dialogue in dialogues:
        if only and dialogue.id not in only:
            continue
        with tempfile.TemporaryDirectory() as directory:
            with_memory = {**base, "memory": {"profile": "passenger", "file": str(Path(directory) / "passenger.yaml")}}
            for memory, chosen in ((True, with_memory), (False, base)):
                for run, messages in ((1, dialogue.run1), (2, dialogue.run2)):
                    done = _run(scenario, chosen, messages, dialogue.id, run, memory)
                    outcomes += [o for o, said in zip(done, messages, strict=True) if said.expect is not None]
    return outcomes


def summary(outcomes: list[Outcome]) -> dict[str, Any]:
    def count(run: int, memory: bool) -> tuple[int, int]:
        chosen = [o for o in outcomes if o.run == run and o.memory == memory]
        return sum(o.right for o in chosen), len(chosen)

    return {f"run{run}_{'with' if memory else 'without'}_memory": count(run, memory)
            for run in (2, 1) for memory in (True, False)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m agentic_mpc.agent_eval.memory_eval", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--agent", action="append", default=[], metavar="KEY=VALUE",
                        help="an agent setting (VALUE read as YAML), e.g. --agent backend=openai")
    parser.add_argument("--dialogues", type=Path, default=DIALOGUES)
    parser.add_argument("--only", action="append", default=None, help="a dialogue id (repeatable)")
    parser.add_argument("--json", type=Path, default=None, help="write every scored message here")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR, stream=sys.stderr)
    settings = {}
    for pair in args.agent:
        key, sep, value = pair.partition("=")
        if not sep:
            parser.error(f"--agent expects KEY=VALUE, got {pair!r}")
        settings[key] = value if key in ("model", "base_url", "api_key_env") else yaml.safe_load(value)
    try:
        outcomes = evaluate(settings, args.dialogues, set(args.only) if args.only else None)
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as error:
        print(f"memory_eval: {args.dialogues}: cannot use it: {error}", file=sys.stderr)
        return 2
    rows: dict[str, dict[str, str]] = {}
    for o in outcomes:
        cell = rows.setdefault(o.dialogue, {})
        key = f"run{o.run} {'with' if o.memory else 'without'}"
        cell[key] = cell.get(key, "") + ("right " if o.right else "WRONG ")
    print(f"{'dialogue':28} {'run 2 with':12} {'run 2 without':14} {'run 1 with':12} run 1 without")
    for dialogue, cell in rows.items():
        print(f"{dialogue:28} {cell.get('run2 with', '-'):12} {cell.get('run2 without', '-'):14} "
              f"{cell.get('run1 with', '-'):12} {cell.get('run1 without', '-')}")
    totals = summary(outcomes)
    for key, (right, total) in totals.items():
        print(f"{key}: {right} of {total} right")
    if args.json is not None:
        args.json.write_text(json.dumps({"summary": totals, "messages": [vars(o) for o in outcomes]}, indent=1,
                                        default=str), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
