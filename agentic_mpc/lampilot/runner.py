"""One LaMPilot case, inside its run process: its scene in SUMO, the command to the agent, the criterion
judged at every step from the command on; the run's files as for any run, plus ``case.json``.

:func:`run_case` is the batch's run function (``agentic_mpc.lampilot.runner:run_case``): its "scenario file"
is the case file the ``lampilot`` command wrote (everything the run needs: the command, the sample, the
agent's settings), so a run needs neither the LaMPilot directory nor anything else of the batch.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

from agentic_mpc.lampilot.criteria import Judge, StepView, Verdict
from agentic_mpc.lampilot.dataset import Case, Sample, Task
from agentic_mpc.lampilot.scenes import COMMAND_DELAY_S, WARMUP_S, case_scenario

LANE_WIDTH_M = 4.0
VEHICLE_MAX_SPEED_MPS = 40.0
"""highway-env's vehicles' top speed (``Vehicle.MAX_SPEED``): what LaMPilot's scenes let a command ask for, past the
road's 70 mph (31.29 m/s), which highway-env does not enforce (its ``inc_abs_speed32`` asks for 32 m/s)."""
SPEED_REQUESTS = ("lawful", "as_asked")
"""lawful (the default): the tools accept up to the road's limit; as_asked: up to the vehicle's top speed, as
LaMPilot's benchmark does, to compare with its published numbers."""


def read_case(case_file: Path) -> tuple[Case, dict[str, Any]]:
    """The case and the agent's settings of a case file written by :func:`write_case`."""
    data = json.loads(Path(case_file).read_text(encoding="utf-8"))
    sample = Sample(data["sample_index"], data["sample"]["env"], data["sample"]["eval"], data["sample"]["seed"])
    commands = [""] * data["command_index"] + [data["command"]]
    samples = [sample] * (data["sample_index"] + 1)
    task = Task(data["task"], Path(data["task_file"]), tuple(commands), tuple(samples))
    return Case(task, data["command_index"], data["sample_index"]), data["agent"]


def write_case(case: Case, agent: dict[str, Any], path: Path, speed_requests: str = "lawful") -> None:
    sample = case.sample
    data = {"task": case.task.name, "task_file": str(case.task.path), "group": case.task.group,
            "command_index": case.command_index, "command": case.command, "sample_index": case.sample_index,
            "sample": {"env": sample.env, "eval": sample.eval, "seed": sample.seed}, "agent": agent}
    if speed_requests != "lawful":  # lawful case files stay as they were (a resumed batch keeps its runs)
        data["speed_requests"] = speed_requests
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(data, indent=1, sort_keys=True, default=str)
    if not path.is_file() or path.read_text(encoding="utf-8") != text:  # unchanged: the batch keeps its runs
        path.write_text(text, encoding="utf-8")


def step_view(world: Any, road: Any, time_s: float, by_network_lane: bool = False) -> StepView:
    """The criterion's view of the world now (``time_s`` from the command); ``by_network_lane``: the heading against
    the network lane the ego is on (a crossroad, where a turn makes the road another route)."""
    from agentic_mpc.world.lanes import situation_of

    observation, state = world.observation, world.ego_state
    ego = observation.ego
    situation = situation_of(observation)
    lane = heading_error = None
    off_road = not ego.lane_id
    if not off_road and 0 <= ego.lane_index < len(road.by_index):
        lane = road.position_from_left(ego.lane_index)
        path = road.by_index[ego.lane_index]
        tangent = path.tangents_at(path.project(float(state[0]), float(state[1])))
        heading_error = math.degrees(math.remainder(float(state[2]) - math.atan2(tangent[1], tangent[0]), math.tau))
        outward = ego.lateral_offset_m if lane == 0 else -ego.lateral_offset_m if lane == len(road.by_index) - 1 else 0.0
        off_road = outward > 0.5 * LANE_WIDTH_M
    shoulder = None if road.shoulder_index is None else road.position_from_left(road.shoulder_index)
    edge_id = ego.lane_id.rsplit("_", 1)[0] if ego.lane_id and not ego.lane_id.startswith(":") else ""
    if edge_id and by_network_lane:
        heading_error = _heading_error_deg(world.network.net.getLane(ego.lane_id).getShape(), state)
    return StepView(
        time_s, float(state[3]), None if off_road else lane, shoulder,
        heading_error if heading_error is not None else 0.0, off_road, observation.ego_collided, ego.road_s_m,
        situation.leader_id, situation.leader_gap_m, situation.leader_speed_mps,
        {vehicle_id: s for vehicle_id, (s, _) in situation.positions.items()}, edge_id,
    )


def _heading_error_deg(shape: Any, state: Any) -> float:
    """The ego's heading against the direction of the lane segment nearest to it, in degrees."""
    x, y, phi = float(state[0]), float(state[1]), float(state[2])

    def distance(segment: tuple[Any, Any]) -> float:
        (ax, ay), (bx, by) = segment
        length2 = (bx - ax) ** 2 + (by - ay) ** 2 or 1e-9
        t = min(1.0, max(0.0, ((x - ax) * (bx - ax) + (y - ay) * (by - ay)) / length2))
        return math.hypot(ax + t * (bx - ax) - x, ay + t * (by - ay) - y)

    (ax, ay), (bx, by) = min(zip(shape, shape[1:]), key=distance)
    return math.degrees(math.remainder(phi - math.atan2(by - ay, bx - ax), math.tau))


def run_case(case_file: Path, variant: str, seed: int, out_dir: Path) -> dict[str, Any]:
    """Run one case into ``out_dir``; returns its summary row (the run's metrics and the case's verdict)."""
    from agentic_mpc.scenario.runner import build_loop, build_world
    from agentic_mpc.shipped import nets_dir

    case, agent = read_case(case_file)
    scenario = case_scenario(case, agent, nets_dir())
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    world = build_world(scenario)
    as_asked = json.loads(Path(case_file).read_text(encoding="utf-8")).get("speed_requests") == "as_asked"
    options = {"max_speed_mps": VEHICLE_MAX_SPEED_MPS} if as_asked else None  # the tools' bound, said to the agent
    loop = build_loop(scenario, world, transcript_path=out_dir / "transcript.jsonl", server_options=options)
    command_at_s = WARMUP_S + COMMAND_DELAY_S
    road = world.lanes()
    by_network_lane = case.sample.eval["type"] == "IntersectionEval"
    judge: Judge | None = None
    verdict: Verdict | None = None
    error: BaseException | None = None
    try:
        while not loop.finished and verdict is None:
            loop.step()
            since_s = world.time_s - command_at_s
            if since_s < -1e-9:
                continue
            view = step_view(world, road, since_s, by_network_lane)
            judge = judge or Judge(case.sample.eval, view)
            verdict = judge.update(view)
        if judge is not None and verdict is None:
            verdict = judge.time_out(step_view(world, road, world.time_s - command_at_s, by_network_lane))
    except BaseException as failure:  # what was recorded is written; the batch records the failure
        error = failure
        raise
    finally:
        loop.close()
        identity = {"scenario": scenario.name, "variant": variant, "seed": seed}
        summary = loop.recorder.write(out_dir, identity, loop.transcript, time.perf_counter() - started, error)
        row = {**summary, **case_columns(case, judge, verdict)}
        _write_row(out_dir, row)
    return row


def case_columns(case: Case, judge: Judge | None, verdict: Verdict | None) -> dict[str, Any]:
    scores = judge.scores() if judge is not None else Judge.failed_scores()
    return {
        "task": case.task.name, "group": case.task.group, "case": case.case_id, "command": case.command,
        "success": bool(verdict and verdict.success), "reason": verdict.reason if verdict else "not started",
        "decided_at_s": round(verdict.time_s, 3) if verdict else math.nan,
        "collided": bool(verdict and verdict.reason == "collision"),
        "target": judge.target if judge is not None and judge.target is not None else math.nan,
        "min_ttc_s": round(judge.min_ttc_s, 3) if judge is not None and math.isfinite(judge.min_ttc_s) else math.inf,
        **scores,
    }


def _write_row(out_dir: Path, row: dict[str, Any]) -> None:
    import pandas as pd

    pd.DataFrame([row]).to_csv(out_dir / "summary.csv", index=False)
    (out_dir / "case.json").write_text(json.dumps(row, indent=1, default=str), encoding="utf-8")
