"""Lane geometry read with sumolib agrees with SUMO's own; roles, edges and along-road positions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agentic_mpc.sumo.bridge import SumoBridge
from agentic_mpc.sumo.network import NetworkError, RoadNetwork
from agentic_mpc.sumo.scenarios import net_files
from sumo_nets import build

CHAIN_NODES = """<nodes>
    <node id="a" x="0" y="0"/> <node id="b" x="200" y="0"/> <node id="c" x="380" y="90"/> <node id="d" x="500" y="90"/>
</nodes>"""
CHAIN_EDGES = """<edges>
    <edge id="e0" from="a" to="b" numLanes="3" speed="16.67" width="3.5" spreadType="center"/>
    <edge id="e1" from="b" to="c" numLanes="3" speed="16.67" width="3.5" spreadType="center"
          shape="200,0 260,5 310,25 350,55 380,90"/>
    <edge id="e2" from="c" to="d" numLanes="3" speed="16.67" width="3.5" spreadType="center"
          shape="380,90 420,120 500,90"/>
</edges>"""


@pytest.fixture(scope="module")
def chain_net(tmp_path_factory):
    """A road of three edges with curves and two junctions (built with build.py's netconvert call)."""
    directory = tmp_path_factory.mktemp("chain")
    (directory / "chain.nod.xml").write_text(CHAIN_NODES)
    (directory / "chain.edg.xml").write_text(CHAIN_EDGES)
    return build.build_net("chain", False, directory), build.build_net("chain", True, directory)


@pytest.mark.parametrize("lefthand", [False, True])
def test_lane_positions_match_sumo_convert2d_on_curves_and_junctions(lefthand, chain_net):
    """SUMO lane positions are in nominal lengths; on curves lanes differ from their shapes (geometry factor)."""
    net = chain_net[lefthand]
    road = RoadNetwork(net).road("e0")
    assert road.edge_ids == ("e0", "e1", "e2")
    factors = {round(span.geometry_factor, 3) for span in road.spans.values()}
    assert len(factors) > 3  # the test means something: lanes whose shapes differ from their lengths
    worst = 0.0
    with SumoBridge(net) as sumo:
        for edge_id in road.edge_ids:
            for index in range(road.lane_count):
                length = road.network.edge(edge_id).getLane(index).getLength()
                for pos in np.linspace(0.0, length, 9):
                    x, y, _ = road.pose_on_lane(f"{edge_id}_{index}", float(pos))
                    sx, sy = sumo.convert_2d(edge_id, float(pos), index)
                    worst = max(worst, math.hypot(x - sx, y - sy))
    assert worst < 0.02


def test_lane_paths_are_continuous_and_one_lane_width_apart(chain_net):
    road = RoadNetwork(chain_net[0]).road("e0")
    for index, path in enumerate(road.lane_paths):
        spans = sorted((span for span in road.spans.values() if span.road_lane_index == index),
                       key=lambda span: span.start_s_m)
        assert [span.lane_id.startswith(":") for span in spans] == [False, True] * 2 + [False]  # junction lanes in
        for before, after in zip(spans, spans[1:]):  # each lane starts where the previous one ends
            assert after.start_s_m == pytest.approx(before.start_s_m + before.shape_length_m, abs=0.01)
        assert path.length_m == pytest.approx(spans[-1].start_s_m + spans[-1].shape_length_m)
    centre = road.lane_path("center")
    for role in ("left", "right"):
        path = road.lane_path(role)
        samples = path.points_at(np.linspace(20.0, path.length_m - 20.0, 50))
        offsets = centre.lateral_offset(samples[:, 0], samples[:, 1])
        expected = 3.5 if role == "left" else -3.5
        assert offsets == pytest.approx(np.full(50, expected), abs=0.02)


def test_road_edges_lie_half_the_road_width_from_the_centre_line():
    road = RoadNetwork(net_files("emergency", lefthand=True)[0]).road("emergency")
    assert road.width_m == pytest.approx(11.25)
    for edge, sign in ((road.left_edge, 1.0), (road.right_edge, -1.0)):
        points = edge.points_at(np.linspace(0.0, edge.length_m, 20))
        assert road.lateral_from_reference(points[:, 0], points[:, 1]) == pytest.approx(
            np.full(20, sign * 11.25 / 2), abs=1e-6
        )


def test_along_road_positions_and_local_projection():
    road = RoadNetwork(net_files("curvy")[0]).road("curvy")
    table = road.reference_table
    for s in (10.0, 400.0, 995.0, 1500.0):  # straights and curves
        (x, y), (tx, ty) = road.reference.points_at([s])[0], road.reference.tangents_at([s])[0]
        px, py = x - 1.3 * ty, y + 1.3 * tx  # 1.3 m left of the centre line
        located_s, lateral = table.locate(px, py, s + 3.0)
        assert located_s == pytest.approx(s, abs=1e-6)
        assert lateral == pytest.approx(1.3, abs=1e-6)
        assert float(road.road_s(px, py)[0]) == pytest.approx(s, abs=1e-6)
    assert road.contains(*road.reference.points_at([100.0])[0])
    assert not road.contains(0.0, 50.0)


def test_roles_and_neighbours():
    road = RoadNetwork(net_files("straight")[0]).road("straight")
    assert road.lane_index("center") == 1 and road.lane_role(2) == "left"
    assert road.lane_neighbour(1, "left") == 2 and road.lane_neighbour(2, "left") is None
    with pytest.raises(NetworkError, match="lane index 3 out of range"):
        road.lane_index(3)
    with pytest.raises(NetworkError, match="no 'middle' lane"):
        road.lane_index("middle")


def test_bad_network_files_are_named(tmp_path):
    with pytest.raises(NetworkError, match="not found"):
        RoadNetwork(tmp_path / "missing.net.xml")
    broken = tmp_path / "broken.net.xml"
    broken.write_text("<net><edge id='x'")
    with pytest.raises(NetworkError, match="malformed network file .*broken.net.xml"):
        RoadNetwork(broken)
    with pytest.raises(NetworkError, match="no edge 'nope'"):
        RoadNetwork(net_files("straight")[0]).road("nope")
