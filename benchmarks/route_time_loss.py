"""Time lost on a route against SUMO's own driver: the same scenario, seed and traffic, once with our ego (the run's
``time_to_goal_s`` from a batch's summary) and once with a SUMO-driven car of the ego's vType in its place (Krauss,
its speedDev 0: it keeps the limit) on the same route, from the same start, timed to the same goal.

    .venv/bin/python benchmarks/route_time_loss.py scenarios/junction_osm_route.yaml BATCH_DIR [--variant base]

Prints one line per seed of ``BATCH_DIR/summary.csv`` (ours, SUMO's, the difference) and the medians. SUMO's car
runs in a process of its own per seed (libsumo runs one simulation per process). Both clocks start when the ego
would enter (after the warm-up).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path


def sumo_driver_time_s(scenario_file: Path, variant: str, seed: int, limit_s: float = 900.0) -> float:
    """Seconds SUMO's car takes from the ego's start to the ego's goal (NaN if it does not get there)."""
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.sumo.network import RoadNetwork
    from agentic_mpc.sumo.start import open_bridge

    config = load_scenario(scenario_file).variant(variant).world
    road = RoadNetwork(config.net_file).road(config.road)
    goal_s = config.goal_s_m if config.goal_s_m is not None else road.reference.length_m - 40.0
    dt = 0.04
    bridge = open_bridge(config, seed, dt)
    try:
        for _ in range(round(config.warmup_s / dt)):
            bridge.step()
        start_edge = config.ego.edge_id or road.edge_ids[0]
        lane_id = road.sumo_lane_id(start_edge, 0)
        bridge.add_route("sumo_driver_route", road.edge_ids[road.edge_ids.index(start_edge):])
        bridge.add_vehicle("sumo_driver", "sumo_driver_route", config.ego_type_id, lane_index=int(lane_id.rsplit("_", 1)[1]),
                           pos_m=config.ego.pos_m, speed_mps=config.ego.speed_mps)
        started = bridge.time_s
        while bridge.time_s - started < limit_s:
            bridge.step()
            if "sumo_driver" in bridge.arrived:
                return bridge.time_s - started
            if not bridge.has_vehicle("sumo_driver"):
                continue  # not inserted yet
            state = bridge.vehicle_state("sumo_driver")
            located = road.lane_s(state.lane_id, state.lane_pos_m) if state.lane_id else None
            if located is not None and road.lane_to_road_s(*located) >= goal_s:
                return bridge.time_s - started
        return math.nan
    finally:
        bridge.close()


def main(argv: list[str] | None = None) -> int:
    import pandas as pd

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", type=Path)
    parser.add_argument("batch", type=Path, help="a batch directory with this scenario's runs")
    parser.add_argument("--variant", default="base")
    parser.add_argument("--inline-seed", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.inline_seed is not None:
        print(json.dumps({"seed": args.inline_seed,
                          "sumo_s": sumo_driver_time_s(args.scenario, args.variant, args.inline_seed)}))
        return 0
    from agentic_mpc.scenario.schema import load_scenario

    scenario = load_scenario(args.scenario).variant(args.variant)
    summary = pd.read_csv(args.batch / "summary.csv")
    runs = summary[(summary.scenario == scenario.name) & (summary.variant == args.variant)]
    rows = []
    for _, run in runs.sort_values("seed").iterrows():
        out = subprocess.run([sys.executable, __file__, str(args.scenario), str(args.batch), "--variant", args.variant,
                              "--inline-seed", str(int(run.seed))], check=True, capture_output=True, text=True)
        sumo_s = json.loads(out.stdout.strip().splitlines()[-1])["sumo_s"]
        ours_s = float(run.time_to_goal_s) - scenario.world.warmup_s
        rows.append({"seed": int(run.seed), "ours_s": round(ours_s, 2), "sumo_s": round(sumo_s, 2),
                     "lost_s": round(ours_s - sumo_s, 2)})
        print(json.dumps(rows[-1]))
    table = pd.DataFrame(rows)
    done = table.dropna()
    print(json.dumps({"runs": len(table), "both_reached_goal": len(done), "ours_median_s": done.ours_s.median(),
                      "sumo_median_s": done.sumo_s.median(), "lost_median_s": done.lost_s.median(),
                      "lost_max_s": done.lost_s.max()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
