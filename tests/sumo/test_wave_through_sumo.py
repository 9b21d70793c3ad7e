"""The world tells SUMO's driver of a car the ego waves on to go first (``RouteJunctions.let_go_first``: the
vehicle parameter ``junctionModel.ignoreIDs``), and to give way to the ego again once it has left the junction."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from agentic_mpc.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[2]


def test_a_waved_car_ignores_the_ego_at_junctions_until_it_is_on_a_lane_past_the_junction():
    import libsumo

    from agentic_mpc.scenario.runner import build_loop, build_world

    scenario = load_scenario(REPO / "scenarios" / "junction_cross.yaml").variant("left").with_seed(1)
    world = build_world(scenario)
    loop = build_loop(scenario, world, embedded_agent=False)
    try:
        while not world.observation.traffic:
            loop.step()
        ego, car = world.config.ego_id, world.observation.traffic[0]
        standing = (SimpleNamespace(id=car.id, lane_id=":0_6_0"),)  # as if it stood inside the junction
        world.junctions.let_go_first(ego, car.id, standing)
        assert libsumo.vehicle.getParameter(car.id, "junctionModel.ignoreIDs") == ego
        world.junctions.let_go_first(ego, None, (SimpleNamespace(id=car.id, lane_id=":0_16_0"),))  # still inside
        assert libsumo.vehicle.getParameter(car.id, "junctionModel.ignoreIDs") == ego
        world.junctions.let_go_first(ego, None, (SimpleNamespace(id=car.id, lane_id="2fo_0"),))  # past it
        assert libsumo.vehicle.getParameter(car.id, "junctionModel.ignoreIDs") == ""
        assert world.junctions.waved == {}
        world.junctions.waved["gone.0"] = ":0_6_0"  # a car that has left the simulation: nothing to tell
        world.junctions.let_go_first(ego, None, ())
        assert world.junctions.waved == {}
    finally:
        loop.close()
