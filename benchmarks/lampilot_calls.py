"""Which tool calls an agent makes for LaMPilot-Bench's highway commands, scored without driving: right, wrong
(a call the task does not ask for: the worst outcome, a model behind ``rules_first`` never sees the message) or
none (the agent said it did not understand, or asked back).

    .venv/bin/python benchmarks/lampilot_calls.py DIR [--phrasings FILE] [--scenes 1] [--backend rules]
        [--model-path M.gguf] [--rules-first] [--out calls.csv]

DIR is a LaMPilot-format directory (e.g. ../shared/benchmarks/lampilot/DbLv1); ``--phrasings`` replaces its
commands (``benchmarks/lampilot_phrasings/*.yaml``). Each (phrasing x scene) starts the case's SUMO scene, sends
the command to a fresh agent (lockstep, the scene's tools) and reads the calls it applied. The closed-loop
completion of the same cases is ``agentic-mpc lampilot DIR --phrasings FILE --scenes N``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SPEED_TOLERANCE_MPS = 0.3


def expected(task: str, evaluation: dict[str, Any], v_now_mps: float, limit_mps: float) -> str:
    """What a right answer does, as a short description used by :func:`verdict`."""
    kind = evaluation["type"]
    if kind == "ACCEvalbySpeed":
        wanted = evaluation["speed"] if "speed" in evaluation else v_now_mps + evaluation["rel_speed"]
        return f"speed {min(wanted, limit_mps):.3f}"
    if kind == "ACCEvalbyDistance":
        return (f"gap {evaluation['distance']}" if "distance" in evaluation
                else f"gap_change {evaluation['rel_distance']}")
    if kind == "LaneChangeEval":
        return f"lane {evaluation['direction']}"
    if kind == "OvertakeEval":
        return f"overtake {evaluation['direction']}"
    return "pull_over"


def verdict(want: str, calls: list[dict[str, Any]], v_now_mps: float, lane_of: dict[str, str]) -> str:
    """right / wrong / none for the applied ``calls`` against ``want`` (:func:`expected`)."""
    if not calls:
        return "none"
    kind, _, value = want.partition(" ")
    ok = False
    for call in calls:
        tool, args = call["tool"], call["arguments"]
        if kind == "speed":
            speed = args.get("v_ref")
            if tool == "change_reference_speed":
                speed = v_now_mps + args.get("change", 0.0)
            ok |= speed is not None and abs(float(speed) - float(value)) <= SPEED_TOLERANCE_MPS
        elif kind == "gap":
            ok |= tool == "set_following_distance" and abs(args.get("gap", -1) - float(value)) < 0.5
        elif kind == "gap_change":
            ok |= tool == "change_following_distance" and abs(args.get("change", 0) - float(value)) < 0.5
        elif kind == "lane":
            ok |= (tool == "change_lane" and args.get("direction") == value) or lane_of.get(tool) == value
        elif kind == "overtake":
            ok |= tool == "overtake" and args.get("side") == value
        else:
            ok |= tool == "pull_over"
    return "right" if ok and len(calls) == 1 else "wrong"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("directory", type=Path)
    parser.add_argument("--phrasings", type=Path)
    parser.add_argument("--scenes", type=int, default=1)
    parser.add_argument("--backend", default="rules")
    parser.add_argument("--model-path")
    parser.add_argument("--rules-first", action="store_true")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()

    from agentic_mpc.agent.settings import agent_settings
    from agentic_mpc.commands.lampilot import with_phrasings
    from agentic_mpc.lampilot.dataset import UNSUPPORTED_GROUPS, Case, load_tasks
    from agentic_mpc.lampilot.scenes import case_scenario
    from agentic_mpc.run.loop import AgentSetup
    from agentic_mpc.scenario.runner import build_loop, build_world
    from agentic_mpc.shipped import nets_dir

    tasks = load_tasks(args.directory)
    if args.phrasings:
        tasks = with_phrasings(tasks, args.phrasings)
    raw = {"backend": args.backend, "mode": "lockstep", "latency_s": 0.0}
    if args.model_path:
        raw.update(model_path=args.model_path, threads=1)
    if args.backend != "rules":
        raw["rules_first"] = args.rules_first
    settings = agent_settings(raw)
    rows = []
    for task in tasks:
        if task.group in UNSUPPORTED_GROUPS:
            continue
        for sample_index in range(min(args.scenes, len(task.samples))):
            for command_index, command in enumerate(task.commands):
                case = Case(dataclasses.replace(task), command_index, sample_index)
                scenario = case_scenario(case, settings.model_dump(mode="json"), nets_dir())
                world = build_world(scenario)
                backend = settings.build_backend(world.lanes().lefthand)
                lanes = world.lanes()
                here = world.observation.ego.lane_index
                lane_of = {}
                for side in ("left", "right"):
                    index = lanes.neighbour(here, side) if here is not None else None
                    if index is not None:
                        lane_of[f"run_{lanes.label(index)}_lane"] = side
                v_now = float(world.ego_state[3])
                with build_loop(scenario, world, agent=AgentSetup(backend, settings.agent_config())) as loop:
                    v_now = loop.slot.current.get("path_tracking").v_ref_mps
                    report = loop.agent.deliver(command).result()
                want = expected(task.name, task.samples[sample_index].eval, v_now, lanes.speed_limit_mps)
                calls = report.applied_calls
                rows.append({"task": task.name, "scene": sample_index, "command": command, "expected": want,
                             "calls": "; ".join(f"{c['tool']}({c['arguments']})" for c in calls),
                             "verdict": verdict(want, calls, v_now, lane_of), "reply": (report.text or "")[:200]})
    counts = {v: sum(r["verdict"] == v for r in rows) for v in ("right", "wrong", "none")}
    total = len(rows) or 1
    print(f"{len(rows)} cases: right {counts['right']} ({100 * counts['right'] / total:.1f} %), wrong "
          f"{counts['wrong']} ({100 * counts['wrong'] / total:.1f} %), no call {counts['none']} "
          f"({100 * counts['none'] / total:.1f} %)")
    for row in rows:
        if row["verdict"] != "right":
            print(f"  {row['verdict']:5} {row['task']:16} {row['command']!r}: {row['calls'] or row['reply'][:100]}")
    if args.out:
        with args.out.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
