"""Which movements cross the ego's way through a junction (``agentic_mpc.sumo.junctions``): a crossing movement is
followed back through its internal lanes to the lane that enters the junction. In an OpenStreetMap cluster the
part of a left turn that crosses the ego's way is its second internal lane; a car on the first is already on its
way, and the lane that enters the junction feeds the first, not the crossing part."""

from __future__ import annotations

from agentic_mpc.sumo.config import installed_sumo_file
from agentic_mpc.sumo.junctions import _entries
from agentic_mpc.sumo.network import RoadNetwork

CLUSTER = ":cluster_1560223815_1560223847_301292612_56231397"


def test_a_crossing_part_inside_a_cluster_is_reached_through_the_internal_lane_before_it():
    net = RoadNetwork(installed_sumo_file("sumo:tools/game/DRT/osm.net.xml")).net
    second_part = net.getLane(f"{CLUSTER}_16_0")  # the northbound left turn's part across the westbound left turn
    entries = {(lane.getID(), inside) for lane, inside in _entries(second_part, frozenset())}
    first_part = net.getLane(f"{CLUSTER}_6_0")
    entering = {lane.getID() for lane in first_part.getIncoming()}  # the northbound approach's lane
    assert {(lane, (first_part.getID(),)) for lane in entering} <= entries and entering
    assert all(not lane.startswith(":") for lane, _ in entries)
    # the ego's own road is never a crossing movement's entry (it merges there, it does not cross)
    own = frozenset(net.getLane(lane).getEdge().getID() for lane in entering)
    assert not {lane for lane, _ in _entries(second_part, own) if lane in entering}
