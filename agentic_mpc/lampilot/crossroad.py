"""LaMPilot's ``dt-intersection-v0`` rebuilt in SUMO (``sumo_nets/lampilot_crossroad``), as its README describes
it: a four-way crossroad, one 4 m lane each way, 10 m/s everywhere, arms of 100 m; the ego's north-south road stops
at a stop sign (SUMO's ``priority_stop``: the east-west road has priority). The ego enters 10 m into the south
approach at 10 m/s after the scene's 3 s, heading for the crossroad; its route goes straight on until the command
chooses the way (``turn_at_next_junction``). Cross traffic goes straight only: ``num_vehicles_right`` from the east,
``num_vehicles_left`` from the west, spread over the first 100 m of their approaches at about 8 m/s (deviation 0.5;
at least 12 m apart), IDM drivers; the sample's seed draws them. Success: :data:`~agentic_mpc.lampilot.criteria.EXITS`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

SPEED_LIMIT_MPS = 10.0
APPROACH_M = 100.0
EGO_START_M = 10.0
CAR_LENGTH_M = 5.0
EGO_LENGTH_M = 5.2
MIN_SPACING_M = 12.0
CROSS_TRAFFIC = {"num_vehicles_right": ("east_in", "west_out"), "num_vehicles_left": ("west_in", "east_out")}


def cross_traffic(env: dict[str, Any], seed: int) -> list[dict[str, Any]]:
    """The scenario's cross-traffic vehicles (id, edge, its route, front position, speed)."""
    rng = np.random.default_rng(seed)
    vehicles = []
    for key, (approach, exit_edge) in CROSS_TRAFFIC.items():
        count = int(env.get(key) or 0)
        positions: list[float] = []
        for _ in range(50 * count):  # drawn until they fit, at least MIN_SPACING_M apart
            if len(positions) == count:
                break
            x = float(rng.uniform(CAR_LENGTH_M, APPROACH_M - MIN_SPACING_M))  # the edge ends before the centre
            if all(abs(x - other) >= MIN_SPACING_M for other in positions):
                positions.append(x)
        for n, x in enumerate(sorted(positions)):
            speed = float(np.clip(rng.normal(8.0, 0.5), 0.0, SPEED_LIMIT_MPS))
            vehicles.append({"id": f"{approach}_{n}", "type_id": "car", "edge_id": approach, "lane": 0,
                             "route": [approach, exit_edge], "pos_m": round(x, 3), "speed_mps": round(speed, 3),
                             "max_speed_mps": round(max(speed, 0.1), 3), "lane_changes": False})
    return vehicles


def intersection_scenario(name: str, command: str, env: dict[str, Any], seed: int, agent: dict[str, Any],
                          nets_dir: Path, warmup_s: float, command_at_s: float, time_limit_s: float) -> dict[str, Any]:
    """The scenario (as a mapping for :class:`~agentic_mpc.scenario.schema.Scenario`) of one crossroad case."""
    return {
        "name": name,
        "description": command,
        "simulation": {
            "net_file": nets_dir / "lampilot_crossroad.net.xml",
            "route_files": [nets_dir / "lampilot.rou.xml"],
            "road": {"from": "south_in", "to": "north_out"},
            "vehicle_model": "urban",
            "warmup_s": warmup_s,
            "ego": {"edge_id": "south_in", "lane": 0, "pos_m": EGO_START_M + 0.5 * EGO_LENGTH_M,
                    "speed_mps": SPEED_LIMIT_MPS},
            "vehicles": cross_traffic(env, seed),
            "goal_s_m": 2.0 * APPROACH_M - 20.0,
        },
        "specification": {"path_tracking": {"lane": "center", "v_ref_mps": SPEED_LIMIT_MPS}},
        "agent": agent,
        "messages": [{"at_s": command_at_s, "text": command}],
        "duration_s": command_at_s + time_limit_s + 0.5,
        "stop_at_goal": False,
        "seed": seed,
        "outputs": {"plot": False, "replay": False},
    }
