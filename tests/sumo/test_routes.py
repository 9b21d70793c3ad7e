"""Routes through real networks: SUMO's own signalised crossroad (``sumo:tools/game/cross``, from the installed
wheel), the ego's one lane through its junctions, the junctions it reads each step, and a closed-loop run that
stops for red and turns."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.scenario.yaml_source import ScenarioFileError
from agentic_mpc.sumo.config import RouteEnds, installed_sumo_file
from agentic_mpc.sumo.network import NetworkError, RoadNetwork

REPO = Path(__file__).resolve().parents[2]
CROSS = installed_sumo_file("sumo:tools/game/cross/cross.net.xml")
SCENARIO = REPO / "scenarios" / "junction_cross.yaml"


def ends(from_edge: str, to_edge: str, *via: str) -> RouteEnds:
    return RouteEnds.model_validate({"from": from_edge, "via": via, "to": to_edge})


def test_a_sumo_path_names_a_file_of_the_installed_package():
    assert CROSS.is_file() and CROSS.parts[-4:] == ("tools", "game", "cross", "cross.net.xml")
    assert installed_sumo_file("../sumo_nets/straight.net.xml") == "../sumo_nets/straight.net.xml"


@pytest.mark.parametrize(("to_edge", "turn_deg"), [("2fo", 0.0), ("4fo", 90.0), ("3fo", -90.0)])
def test_sumos_router_finds_the_route_and_the_ego_gets_one_connected_lane_through_it(to_edge, turn_deg):
    road = RoadNetwork(CROSS).road(ends("1fi", to_edge))
    assert road.is_route and road.lane_count == 1 and road.edge_ids[0] == "1fi" and road.edge_ids[-1] == to_edge
    shapes = [piece.shape for piece, _ in road.pieces]
    assert max(math.dist(a[-1], b[0]) for a, b in zip(shapes, shapes[1:])) < 1.0  # each piece leads on
    xy = road.lane_paths[0].coordinates
    heading = np.unwrap(np.arctan2(*np.diff(xy, axis=0).T[::-1]))
    assert math.degrees(heading[-1] - heading[0]) == pytest.approx(turn_deg, abs=12.0)
    internal = [piece for piece, _ in road.pieces if piece.internal]
    assert {piece.junction_id for piece in internal} >= {"0"}  # through the signalised junction
    assert [start for _, start in road.pieces] == sorted(start for _, start in road.pieces)


def test_a_position_on_a_turns_second_internal_lane_lies_after_its_first_on_the_route():
    """A left turn through SUMO's internal junction is two internal lanes (the second after the waiting point): a
    car at the start of the second part is as far along the route as one at the end of the first (it was mapped
    back to the junction's start, and the ego drove into a car it took to be beside it: junction_cross left)."""
    road = RoadNetwork(CROSS).road(ends("1fi", "4fo"))
    first, second = next(piece for piece, _ in road.pieces if piece.internal and piece.junction_id == "0").lane_ids
    net = road.network.net
    end_of_first = road.lane_s(first, net.getLane(first).getLength())
    assert road.lane_s(second, 0.0) == pytest.approx(end_of_first, abs=0.01)
    x, y = net.getLane(second).getShape()[-1]  # the second part's end: where the path says it is
    index, lane_s = road.lane_s(second, net.getLane(second).getLength())
    assert road.lane_to_road_s(index, lane_s) == pytest.approx(road.road_s(x, y)[0], abs=1.0)


def test_an_edges_lanes_where_the_route_moves_over_lie_side_by_side_on_it():
    """Where the route moves over to the lane that leads on, along an edge, both lanes of the edge start where the
    edge does: a truck standing in the lane moved over to was placed 48 m ahead of where it stood, and the ego drove
    into it (tuning seed 302)."""
    network = RoadNetwork(installed_sumo_file("sumo:tools/game/DRT/osm.net.xml"))
    road = network.road(ends("153021549", "142575692#6", "-142575658#1"))
    side_by_side = [piece for piece, _ in road.pieces if not piece.internal and len(piece.lane_ids) > 1]
    assert side_by_side  # (the scenario's route moves over on two edges)
    for piece in side_by_side:
        assert len({road.spans[lane].start_s_m for lane in piece.lane_ids}) == 1


def test_the_turns_slower_lanes_are_speed_zones_of_the_route():
    road = RoadNetwork(CROSS).road(ends("1fi", "3fo"))  # a right turn
    assert road.speed_limit_mps == pytest.approx(13.89)
    assert any(limit < 10.0 for _, _, limit in road.speed_zones)
    assert all(start < end for start, end, _ in road.speed_zones)


def test_a_route_that_is_not_connected_or_names_no_edge_is_refused_naming_the_edge():
    network = RoadNetwork(CROSS)
    with pytest.raises(NetworkError, match="edge '1fi' does not lead to '2o'"):
        network.road(("1fi", "2o"))
    with pytest.raises(NetworkError, match="no edge 'nowhere'"):
        network.road(ends("1fi", "nowhere"))
    with pytest.raises(NetworkError, match="no route from '2fo' to '1fi'"):
        network.road(ends("2fo", "1fi"))  # 2fo ends at a dead end


def test_a_route_through_a_via_edge_and_a_junction_whose_own_lanes_run_backwards_is_one_smooth_path():
    """SUMO's OpenStreetMap import: at junction 1685653005 the internal lane points against both of its lanes."""
    osm = RoadNetwork(installed_sumo_file("sumo:tools/game/DRT/osm.net.xml"))
    road = osm.road(ends("153021549", "142575692#6", "-142575658#1"))
    assert "-142575658#1" in road.edge_ids and road.reference.length_m > 2000.0
    xy = road.lane_paths[0].coordinates
    heading = np.arctan2(*np.diff(xy, axis=0).T[::-1])
    turn = np.abs(np.angle(np.exp(1j * np.diff(heading))))
    assert np.degrees(turn.max()) < 60.0  # no reversal between vertices anywhere on 2.8 km


def test_a_scenario_with_a_missing_sumo_file_or_a_bad_route_fails_before_sumo_starts(tmp_path):
    text = SCENARIO.read_text(encoding="utf-8").replace("../sumo_nets/", str(REPO / "sumo_nets") + "/")
    (tmp_path / "a.yaml").write_text(text.replace("cross/cross.net.xml", "cross/crosss.net.xml"), encoding="utf-8")
    with pytest.raises(ScenarioFileError, match=r"a\.yaml:\d+: simulation\.net_file: file not found: .*crosss"):
        load_scenario(tmp_path / "a.yaml")
    (tmp_path / "b.yaml").write_text(text.replace("{from: 1fi, to: 2fo}", "{from: 1fi}"), encoding="utf-8")
    with pytest.raises(ScenarioFileError, match=r"b\.yaml:\d+: simulation\.road"):
        load_scenario(tmp_path / "b.yaml")


@pytest.fixture(scope="module")
def straight_run(tmp_path_factory):
    from agentic_mpc.scenario.runner import run_to_directory

    out = tmp_path_factory.mktemp("cross")
    return run_to_directory(SCENARIO, "straight", 1, out), out


def test_the_ego_stops_for_red_goes_on_green_and_completes_its_route(straight_run):
    import pandas as pd

    summary, out = straight_run
    assert summary["status"] == "ok", summary["error"]
    assert summary["route_completed"] and summary["red_light_violations"] == 0
    assert summary["collisions_ego_at_fault"] == 0 and summary["junctions_passed"] >= 1
    events = pd.read_csv(out / "events.csv")
    entered = events[(events.event == "junction_entered") & (events.content.astype(str) == "0")]
    assert len(entered) == 1 and '"signal": "green"' in entered.result.iloc[0]
    trajectory = pd.read_csv(out / "trajectory.csv")
    assert trajectory.v_mps.min() < 0.1  # it stood (for red, or behind the queue at red)


def test_the_agent_turns_at_the_next_junction_through_mcp_and_the_car_drives_the_new_route():
    """SUMO's cross, the straight route: over MCP, sumo://route says what the junction offers; a way it does not
    offer is refused with the reason and the car keeps its route; "left" takes it out of the west arm, 4fo."""
    import asyncio
    import json

    from mcp import Client

    from agentic_mpc.scenario.runner import build_loop, build_world

    scenario = load_scenario(SCENARIO).variant("straight").with_seed(3)
    world = build_world(scenario)
    loop = build_loop(scenario, world, embedded_agent=False)

    async def over_mcp():
        async with Client(loop.server.mcp_server, cache=None) as client:
            tools = {t.name: t for t in (await client.list_tools()).tools}
            route = json.loads((await client.read_resource("sumo://route")).contents[0].text)
            refused = await client.call_tool("drive_to", {"edge": "1fo"})  # back where it came from: no way there
            turned = await client.call_tool("turn_at_next_junction", {"direction": "left"})
            return tools, route, refused, turned

    try:
        loop.step()
        tools, route, refused, turned = asyncio.run(over_mcp())
        assert tools["turn_at_next_junction"].input_schema["properties"]["direction"]["enum"] == [
            "left", "right", "straight"]
        assert route["edges"] == ["1fi", "1si", "2o", "2fo"] and route["on_edge"] == "1fi"
        assert route["next_choice"]["directions"] == ["left", "right", "straight"]
        assert route["next_choice"]["route_goes"] == "straight" and route["next_choice"]["junction_id"] == "0"
        assert refused.is_error and "no route from '1fi' to '1fo'" in refused.content[0].text
        assert "the car keeps its route" in refused.content[0].text
        assert not turned.is_error
        while not loop.finished:
            loop.step()
        assert world.road.edge_ids == ("1fi", "1si", "4o", "4fo") and world.road_version == 1
        assert world.observation.ego.edge_id == "4fo" and world.observation.ego.road_s_m >= world.goal_s_m
        assert loop.recorder.metrics.junctions.red_light_violations == 0
    finally:
        loop.close()


def test_a_lane_off_the_route_reaches_back_to_where_a_long_vehicle_entering_it_has_its_centre():
    """SUMO puts a vehicle on the lane its front is on: a 12 m truck turning off has its centre up to 6 m before
    that lane's start, and its prediction along the lane must start there, not at the lane's start (tuning seed
    318: the cover sat ahead of the truck's body and the ego drove into its rear)."""
    from agentic_mpc.sumo.lane_tables import BEHIND_M, LaneTables

    network = RoadNetwork(installed_sumo_file("sumo:tools/game/DRT/osm.net.xml"))
    turn = network.net.getLane(":cluster_1704693650_1866350919_38920778_671564358_3_0")
    (before,) = turn.getIncoming()
    path = LaneTables(network.net).table(turn.getID())[1]
    x, y = before.getShape()[-1]  # the turn's start
    assert path.project(x, y) == pytest.approx(BEHIND_M, abs=0.01)
    bx, by = before.getShape()[-2]  # further back on the lane before it
    assert 0.0 < path.project(bx, by) < BEHIND_M
