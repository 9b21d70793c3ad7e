"""The paper's scenarios driven to the end with a given backend: ``agentic-mpc eval-agent --closed-loop``.

Scenario 1 (steering preference, SUMO) with the passenger asking for the left and for the right side, and
Scenario 2 (the ambulance, SUMO, left-hand traffic) with the passenger asking to let it pass, each over
``seeds`` seeds, through the normal runner (``scenario.runner.run_scenario``) with the scenario's ``agent:``
settings overridden by ``configure`` (the command passes ``commands.with_agent_settings``); Scenario 2 also runs once per seed without a message
(no agent call), the holding baseline the ambulance's delay is compared with. Per run: the side the car
passed the obstacle on, collisions, the ambulance's delay, the tool calls the agent made, and what its steps
cost: their wall time, the model's own time for their tokens (as its server reported them) and the ratio, and
the sim time from the first message to the first accepted call (in realtime mode the car drove on meanwhile).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agentic_mpc.shipped import scenarios_dir

SCENARIO_1 = scenarios_dir() / "paper_steering_preference.yaml"
SCENARIO_2 = scenarios_dir() / "paper_emergency_response.yaml"


@dataclass(frozen=True, slots=True)
class ClosedLoopRun:
    scenario: Path
    variant: str
    wants: str
    """What the paper's outcome is: the obstacle side, "yield", or "hold" (the no-message baseline)."""
    uses_agent: bool = True


RUNS = (
    ClosedLoopRun(SCENARIO_1, "message_left", "left"),
    ClosedLoopRun(SCENARIO_1, "message_right", "right"),
    ClosedLoopRun(SCENARIO_2, "yield", "yield"),
    ClosedLoopRun(SCENARIO_2, "no_message", "hold", uses_agent=False),
)

COLUMNS = ("scenario", "variant", "seed", "status", "wants", "obstacle_side", "as_asked", "collisions",
           "collisions_ego_at_fault", "ambulance_delay_s", "delay_saved_s", "agent_tool_calls", "calls", "agent_steps",
           "agent_wall_s", "model_s", "wall_per_model", "first_call_after_s", "wall_s")


def _calls(out_dir: Path) -> list[str]:
    """The tool calls the server accepted, from the run's transcript."""
    calls = []
    for record in _records(out_dir):
        if record.get("event") == "tool_result" and not record.get("is_error"):
            arguments = ", ".join(f"{k}={v!r}" for k, v in (record.get("arguments") or {}).items())
            calls.append(f"{record.get('tool')}({arguments})")
    return calls


def _records(out_dir: Path) -> list[dict[str, Any]]:
    path = out_dir / "transcript.jsonl"
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def agent_timing(out_dir: Path) -> dict[str, Any]:
    """What the run's agent steps cost (from its transcript): steps, their wall time and the model's own time
    summed, the ratio, and the sim seconds from the first user message to the first accepted call."""
    records = _records(out_dir)
    steps = [r for r in records if r.get("event") == "step_end"]
    wall = sum(float(r.get("wall_s") or 0.0) for r in steps)
    timed = [float(r["model_s"]) for r in steps if r.get("model_s") is not None]
    message_at = next((r.get("sim_time_s") for r in records
                       if r.get("event") == "message" and r.get("role") == "user"), None)
    applied_at = next((r.get("sim_time_s") for r in records
                       if r.get("event") == "tool_result" and not r.get("is_error")), None)
    after = (round(float(applied_at) - float(message_at), 3)
             if isinstance(message_at, int | float) and isinstance(applied_at, int | float) else "")
    model = sum(timed) if timed else None
    return {"agent_steps": len(steps), "agent_wall_s": round(wall, 3),
            "model_s": "" if model is None else round(model, 3),
            "wall_per_model": round(wall / model, 3) if model else "", "first_call_after_s": after}


def run_closed_loop(configure: Callable[[Any], Any], seeds: int, out_dir: Path,
                    progress: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Every run of :data:`RUNS` for seeds 0..seeds-1, ``configure(scenario)`` setting the agent of those
    that use one; one row per run (see :data:`COLUMNS`)."""
    from agentic_mpc.scenario.runner import run_scenario
    from agentic_mpc.scenario.schema import load_scenario

    rows: list[dict[str, Any]] = []
    for seed in range(seeds):
        held_delay_s = float("nan")
        for run in sorted(RUNS, key=lambda r: r.uses_agent):  # the baseline first: the yield run compares to it
            scenario = load_scenario(run.scenario).variant(run.variant).with_seed(seed)
            if run.uses_agent:
                scenario = configure(scenario)
            outputs = scenario.outputs.model_copy(update={"replay": False, "plot": False})
            scenario = scenario.model_copy(update={"outputs": outputs})
            where = out_dir / scenario.name / run.variant / f"seed-{seed}"
            try:
                summary = run_scenario(scenario, where)
                status = "ok"
            except Exception as error:  # noqa: BLE001 - a failed run is a result too: say why, keep going
                summary, status = {}, f"failed: {str(error)[:200]}"
            side = str(summary.get("obstacle_side") or "")
            delay = float(summary.get("ambulance_delay_s", float("nan")))
            if run.wants == "hold":
                held_delay_s = delay
            row = {
                "scenario": scenario.name, "variant": run.variant, "seed": seed, "status": status,
                "wants": run.wants, "obstacle_side": side,
                "as_asked": (side == run.wants) if run.wants in ("left", "right") else "",
                "collisions": summary.get("collisions", ""),
                "collisions_ego_at_fault": summary.get("collisions_ego_at_fault", ""),
                "ambulance_delay_s": delay,
                "delay_saved_s": round(held_delay_s - delay, 3) if run.wants == "yield" else "",
                "agent_tool_calls": summary.get("agent_tool_calls", ""),
                "calls": "; ".join(_calls(where)), **agent_timing(where), "wall_s": summary.get("wall_s", ""),
            }
            rows.append(row)
            if progress is not None:
                progress(row)
    order = [(r.scenario.stem, r.variant) for r in RUNS]
    return sorted(rows, key=lambda row: (row["seed"], order.index((row["scenario"], row["variant"]))))


def closed_loop_table(rows: list[dict[str, Any]]) -> str:
    header = (f"{'scenario / variant':<44} {'seed':>4} {'side':>6} {'asked':>6} {'coll.':>5} {'amb. delay':>10} "
              f"{'saved':>6}  calls")
    lines = [header]
    for row in rows:
        delay = row["ambulance_delay_s"]
        lines.append(
            f"{row['scenario'] + ' / ' + row['variant']:<44} {row['seed']:>4} {row['obstacle_side'] or '-':>6} "
            f"{str(row['as_asked']) or '-':>6} {row['collisions']!s:>5} "
            f"{'-' if math.isnan(delay) else f'{delay:.1f} s':>10} {str(row['delay_saved_s']) or '-':>6}  "
            f"{row['calls'] or ('(no agent)' if row['wants'] == 'hold' else '(none)')}"
            + ("" if row["status"] == "ok" else f"  [{row['status']}]")
        )
    return "\n".join(lines)
