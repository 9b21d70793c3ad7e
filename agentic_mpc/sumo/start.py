"""SUMO started for a :class:`~agentic_mpc.sumo.config.SumoConfig`: the bridge with the options the config and
its route files call for (the sublane model and the bluelight device's settings where rescue lanes are on)."""

from __future__ import annotations

from agentic_mpc.sumo.bridge import SumoBridge
from agentic_mpc.sumo.config import SumoConfig
from agentic_mpc.sumo.route_files import RouteTypes, read_route_types, rescue_lanes_active


def open_bridge(
    config: SumoConfig, seed: int, step_length_s: float, lefthand: bool | None = None, types: RouteTypes | None = None
) -> SumoBridge:
    """SUMO started for ``config``: its options, and with rescue lanes (resolved from the config and the route
    files) the sublane model, the bluelight reaction distance and the emergency vTypes' parameters."""
    types = types or read_route_types(config.route_files)
    rescue = rescue_lanes_active(config, types)
    bridge = SumoBridge(
        config.net_file, config.route_files, seed=seed, step_length_s=step_length_s,
        lateral_resolution_m=config.lateral_resolution_m if config.sublane or rescue else None,
        bluelight_reaction_dist_m=config.rescue_lanes.reaction_dist_m if rescue else None,
        log_file=config.sumo_log_file, quiet=config.quiet, keep_route=config.keep_route, lefthand=lefthand,
    )
    try:
        if rescue:  # before any vehicle exists: per-vehicle types copy their vType's parameters
            for type_id in types.emergency_types():
                bridge.set_type_parameters(type_id, config.rescue_lanes.emergency_params)
    except BaseException:
        bridge.close()
        raise
    return bridge
