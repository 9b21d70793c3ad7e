"""SUMO is told when the externally driven ego stops at a light (``RouteJunctions.tell_light_stop``): while the
junction rules hold it for red, SUMO's junction logic takes it to stop there (speed mode with bit 4), otherwise to
pass (speed mode 0). Taken to pass a red light, an ego standing at it held oncoming left turners inside an
OpenStreetMap cluster until they stood in its way on green (``junction_osm_route`` seed 303)."""

from __future__ import annotations

from pathlib import Path

from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.sumo.bridge.vehicles import EXTERNAL_SPEED_MODE, STOPPING_AT_LIGHT_SPEED_MODE

REPO = Path(__file__).resolve().parents[2]


def test_sumo_takes_the_ego_to_stop_at_its_red_light_and_to_pass_once_it_goes():
    import libsumo

    from agentic_mpc.scenario.runner import build_loop, build_world

    scenario = load_scenario(REPO / "scenarios" / "junction_cross.yaml").variant("straight").with_seed(1)
    world = build_world(scenario)
    loop = build_loop(scenario, world, embedded_agent=False)
    seen: dict[str, set[int]] = {"held at red": set(), "in the junction": set()}
    try:
        while not loop.finished and world.time_s < 120.0:
            loop.step()
            junction = world.observation.junctions_ahead[0] if world.observation.junctions_ahead else None
            mode = libsumo.vehicle.getSpeedMode(world.config.ego_id)
            if junction is not None and junction.signal == "red" and junction.distance_m > 0.0:
                seen["held at red"].add(mode)
            elif junction is not None and junction.distance_m < 0.0 and not any(
                    j.signal in ("red", "yellow") for j in world.observation.junctions_ahead):
                seen["in the junction"].add(mode)  # (not when it already stops for the next light)
    finally:
        loop.close()
    assert seen["held at red"] == {STOPPING_AT_LIGHT_SPEED_MODE}
    assert seen["in the junction"] == {EXTERNAL_SPEED_MODE}
