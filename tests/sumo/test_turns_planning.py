"""Choosing the way on a network without a simulator: what a junction offers, a turn, a destination
(:mod:`agentic_mpc.sumo.turns`), on SUMO's ``cross`` from the installed wheel."""

from __future__ import annotations

import pytest
import sumolib

from agentic_mpc.sumo.config import installed_sumo_file
from agentic_mpc.sumo.route import RouteError
from agentic_mpc.sumo.turns import next_choice, offered, route_to, straight_on, turned_route

STRAIGHT = ("1fi", "1si", "2o", "2fo")


@pytest.fixture(scope="module")
def net():
    return sumolib.net.readNet(str(installed_sumo_file("sumo:tools/game/cross/cross.net.xml")), withInternal=True)


def test_the_junction_offers_each_way_once_and_no_u_turn(net):
    assert offered(net, "1si") == {"right": "3o", "straight": "2o", "left": "4o"}
    assert offered(net, "1fi") == {"straight": "1si"}  # a joint: nothing to choose
    choice = next_choice(net, STRAIGHT, 0)
    assert (choice.junction_id, choice.incoming_edge, choice.index, choice.route_direction) == ("0", "1si", 1, "straight")


def test_a_turn_keeps_the_route_to_the_junction_and_goes_straight_on_after_it(net):
    assert turned_route(net, STRAIGHT, 0, "left") == ("1fi", "1si", "4o", "4fo")
    assert turned_route(net, STRAIGHT, 1, "right") == ("1fi", "1si", "3o", "3fo")
    assert straight_on(net, "4o") == ("4o", "4fo")


def test_no_junction_ahead_or_a_way_it_does_not_offer_is_refused_with_the_reason(net):
    with pytest.raises(RouteError, match="no junction ahead"):
        turned_route(net, STRAIGHT, 2, "left")
    assert turned_route(net, ("1fi", "1si", "3o"), 0, "straight")[-1] == "2fo"
    osm = sumolib.net.readNet(str(installed_sumo_file("sumo:tools/game/DRT/osm.net.xml")), withInternal=True)
    route = ("-114024904", "-114024903#2")  # an OpenStreetMap junction with no left turn from this street
    with pytest.raises(RouteError, match=r"offers right and straight, not left"):
        turned_route(osm, route, 0, "left")


def test_a_destination_is_routed_from_the_ego_edge_on(net):
    assert route_to(net, STRAIGHT, 1, "3fo") == ("1fi", "1si", "3o", "3fo")
    with pytest.raises(RouteError, match="no route"):
        route_to(net, STRAIGHT, 3, "1fi")
