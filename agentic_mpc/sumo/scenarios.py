"""Ready-made co-simulation configs for the paper's scenarios and the traffic experiments.

The nets and route files are the shipped ones (:func:`agentic_mpc.shipped.nets_dir`;
``AGENTIC_MPC_SUMO_NETS`` overrides where). Every function returns a plain :class:`~agentic_mpc.sumo.config.SumoConfig`; change it
with ``config.replace(...)`` (validated). The seed is the run's: give it to the world and the loop.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from agentic_mpc.shipped import nets_dir
from agentic_mpc.sumo.config import (
    EgoStart,
    RescueLanes,
    StaticObstacle,
    SumoConfig,
    SurroundingsConfig,
    VehicleSpawn,
)


def net_files(name: str, lefthand: bool = False) -> tuple[Path, Path]:
    """(net file, route file) of a net: ``straight``, ``emergency`` or ``curvy``."""
    directory = nets_dir()
    net = directory / f"{name}{'_lefthand' if lefthand else ''}.net.xml"
    return net, directory / f"{name}.rou.xml"


def scenario1_config(obstacle_pos_m: float = 110.0, **update: object) -> SumoConfig:
    """Scenario 1 (steering preference): the ego at 15 m/s on the centre lane of the straight road, a stopped
    car on that lane ``obstacle_pos_m`` ahead of the road start (J2 sees it; SUMO traffic would too)."""
    net, routes = net_files("straight")
    config = SumoConfig(
        net_file=net,
        route_files=(routes,),
        road="straight",
        ego=EgoStart(lane="center", pos_m=30.0, speed_mps=15.0),
        obstacles=(StaticObstacle(id="obstacle", lane="center", pos_m=obstacle_pos_m),),
    )
    return config.replace(**update)


def scenario2_config(
    lefthand: bool = True,
    roadblock: bool = True,
    ambulance_behind_m: float = 90.0,
    **update: object,
) -> SumoConfig:
    """Scenario 2 (emergency response): the ego at 15 m/s on the centre lane, an ambulance coming from behind
    on the same lane at 20 m/s (it wants 25 m/s).

    ``roadblock``: one SUMO car alongside the ego on each neighbouring lane at the ego's speed, without
    lane changes. SUMO's drivers do not yield to an ambulance without the sublane model, so this is the
    situation where the ego's own behaviour decides whether the ambulance gets through: holding the lane
    keeps it stuck, moving to a side lane and stopping opens the centre lane. Without the roadblock the
    ambulance simply overtakes on a free lane. ``lefthand=True`` is the paper's (Japanese) road.

    With the roadblock, rescue lanes are off: SUMO would move the pinned cars aside (the bluelight device
    overrides their lane-change mode), and the yielding ego collided with the left one (measured).
    """
    net, routes = net_files("emergency", lefthand)
    ego_pos = 150.0
    vehicles = [
        VehicleSpawn(id="ambulance", type_id="ambulance", lane="center", pos_m=ego_pos - ambulance_behind_m,
                     speed_mps=20.0),
    ]
    if roadblock:
        for side in ("left", "right"):
            vehicles.append(
                VehicleSpawn(id=f"block_{side}", type_id="car", lane=side, pos_m=ego_pos, speed_mps=15.0,
                             max_speed_mps=15.0, speed_factor=1.0, imperfection=0.0, lane_changes=False)
            )
    config = SumoConfig(
        net_file=net,
        route_files=(routes,),
        road="emergency",
        ego=EgoStart(lane="center", pos_m=ego_pos, speed_mps=15.0),
        vehicles=tuple(vehicles),
        rescue_lanes=RescueLanes(enabled=False) if roadblock else RescueLanes(),
    )
    return config.replace(**update)


def curvy_traffic_config(lane: str | int = "center", warmup_s: float = 90.0, lefthand: bool = False,
                         **update: object) -> SumoConfig:
    """The ego drives one lane of the 1.6 km curved 3-lane road through the route file's background traffic
    (about 1800 veh/h; ``warmup_s`` of SUMO alone fills the road first).

    J0's edges are the ego's lane corridor (``SurroundingsConfig(edges="corridor")``): with the road's edges,
    J1 alone does not hold a lane behind a slower truck (its lateral and lengthwise errors weigh the same,
    so driving 3.5 m off the lane at full speed costs about as much as following at 12 m/s), and the ego
    overtook through the neighbouring lane in 8 of 30 runs (measured).
    """
    net, routes = net_files("curvy", lefthand)
    config = SumoConfig(
        net_file=net,
        route_files=(routes,),
        road="curvy",
        warmup_s=warmup_s,
        ego=EgoStart(lane=lane, pos_m=30.0, speed_mps=15.0),
        surroundings=SurroundingsConfig(edges="corridor"),
    )
    return config.replace(**update)


def traffic_around(
    count: int,
    ego_pos_m: float,
    lanes: int = 3,
    spacing_m: float = 30.0,
    seed: int = 0,
    type_id: str = "car",
) -> tuple[VehicleSpawn, ...]:
    """``count`` SUMO cars spread over the lanes ahead of and behind ``ego_pos_m`` (none on the ego's spot).

    Positions are on a grid ``spacing_m`` apart per lane, staggered between lanes, jittered by up to 2 m
    (``seed``), all at 15 m/s so SUMO finds room to insert every one at once (its drivers' speed factors
    spread them out afterwards).
    """
    rng = np.random.default_rng(seed)
    spawns: list[VehicleSpawn] = []
    slot = 0
    while len(spawns) < count:
        lane = slot % lanes
        row = slot // lanes
        k = (row + 1) // 2 * (1 if row % 2 else -1)  # 0, +1, -1, +2, -2, ...: around the ego
        pos = ego_pos_m + k * spacing_m + lane * spacing_m / lanes + float(rng.uniform(-2.0, 2.0))
        slot += 1
        if abs(pos - ego_pos_m) < 20.0 and lane == 1:
            continue  # keep the ego's own spot (and SUMO's safe insertion gaps around it) free
        if pos < 5.0:
            continue
        spawns.append(
            VehicleSpawn(id=f"car{len(spawns)}", type_id=type_id, lane=lane, pos_m=pos, speed_mps=15.0)
        )
    return tuple(spawns)
