"""The libsumo boundary: conventions, one simulation per process, and errors that name their cause."""

from __future__ import annotations

import math

import pytest

from agentic_mpc.sumo.bridge import (
    SumoAlreadyRunningError,
    SumoBridge,
    SumoError,
    centre_to_front,
    front_to_centre,
)
from agentic_mpc.sumo.scenarios import net_files

NET, ROUTES = net_files("straight")


def test_pose_conversion_front_bumper_and_navigational_angle():
    # Heading east (phi = 0) is SUMO's 90 degrees; the front bumper is half a length ahead of the centre.
    assert centre_to_front(10.0, 2.0, 0.0, 5.0) == pytest.approx((12.5, 2.0, 90.0))
    # Heading north (phi = pi/2) is SUMO's 0 degrees.
    assert centre_to_front(0.0, 0.0, math.pi / 2, 4.0) == pytest.approx((0.0, 2.0, 0.0))
    for phi in (-3.0, -1.0, 0.3, 2.5):
        assert front_to_centre(*centre_to_front(1.0, -2.0, phi, 4.6), 4.6) == pytest.approx((1.0, -2.0, phi))


def test_one_simulation_per_process():
    with SumoBridge(NET, [ROUTES]) as first:
        with pytest.raises(SumoAlreadyRunningError, match="one per process"):
            SumoBridge(NET, [ROUTES])
        assert first.running and first.time_s == 0.0  # the first one is untouched
    with SumoBridge(NET, [ROUTES]) as second:  # after closing, a new one may start
        second.step()
        assert second.time_s == pytest.approx(0.04)


def test_external_vehicle_is_placed_exactly_and_reports_our_speed():
    with SumoBridge(NET, [ROUTES]) as sumo:
        sumo.add_route("r", ["straight"])
        steps = sumo.add_external_vehicle("ego", "r", "ego", lane_index=1, pos_m=50.0, speed_mps=15.0)
        assert steps == 1
        sumo.subscribe_around("ego", 100.0)
        # 20 m/s is above what SUMO would report (its displacement speed is capped at the speed limit).
        x, y, phi = 50.0 - 2.6 + 0.8, 0.3, 0.05
        sumo.move_external("ego", x, y, phi, speed_mps=20.0)
        sumo.step()
        ego, others = sumo.around()
        assert others == []
        assert (ego.x_m, ego.y_m, ego.heading_rad) == pytest.approx((x, y, phi), abs=1e-9)
        assert ego.speed_mps == pytest.approx(20.0)
        assert ego.lane_id == "straight_1"
        assert sumo.vehicle_state("ego").speed_mps == pytest.approx(20.0)


def test_missing_files_are_named(tmp_path):
    with pytest.raises(SumoError, match="network file not found: .*nope.net.xml"):
        SumoBridge(tmp_path / "nope.net.xml", [ROUTES])
    with pytest.raises(SumoError, match="route file not found: .*nope.rou.xml"):
        SumoBridge(NET, [tmp_path / "nope.rou.xml"])


def test_malformed_net_is_refused_before_libsumo_sees_it(tmp_path):
    """libsumo crashes the process on a malformed net: it must never get one."""
    broken = tmp_path / "broken.net.xml"
    broken.write_text("<net version='1.20'><edge id='x'")
    with pytest.raises(SumoError, match="malformed network file .*broken.net.xml"):
        SumoBridge(broken, [ROUTES])
    not_a_net = tmp_path / "routes.net.xml"
    not_a_net.write_text("<routes/>")
    with pytest.raises(SumoError, match="not a SUMO network: its root element is <routes>"):
        SumoBridge(not_a_net, [ROUTES])


def test_malformed_route_file_is_named_and_leaves_no_simulation(tmp_path):
    broken = tmp_path / "broken.rou.xml"
    broken.write_text("<routes><vType id='x'")
    with pytest.raises(SumoError, match="broken.rou.xml"):
        SumoBridge(NET, [broken])
    with SumoBridge(NET, [ROUTES]) as sumo:  # nothing was left half-started
        sumo.step()


def test_a_rejected_command_names_the_vehicle():
    with SumoBridge(NET, [ROUTES]) as sumo:
        with pytest.raises(SumoError, match="cannot add vehicle 'v'.*type 'no_such_type'"):
            sumo.add_vehicle("v", "road", "no_such_type", lane_index=0, pos_m=10.0, speed_mps=0.0)


def test_failure_mid_run_closes_sumo():
    with SumoBridge(NET, [ROUTES]) as sumo:
        sumo.add_route("r", ["straight"])
        sumo.add_external_vehicle("ego", "r", "ego", lane_index=1, pos_m=50.0, speed_mps=15.0)
        sumo.remove_vehicle("ego")
        sumo.step()
        with pytest.raises(SumoError, match=r"SUMO failed at t=0\.08 s while moving 'ego'.*not known"):
            sumo.move_external("ego", 60.0, 0.0, 0.0)
        assert not sumo.running
    with SumoBridge(NET, [ROUTES]):  # closed cleanly: a new simulation starts
        pass


def test_stopped_vehicle_stays_on_its_lane():
    with SumoBridge(NET, [ROUTES]) as sumo:
        sumo.add_stopped_vehicle("obstacle", "road", "obstacle", edge_id="straight", lane_index=1, pos_m=200.0)
        for _ in range(250):
            sumo.step()
        state = sumo.vehicle_state("obstacle")
        assert (state.lane_id, state.speed_mps) == ("straight_1", 0.0)
        assert state.lane_pos_m == pytest.approx(200.0)
        assert (state.x_m, state.y_m) == pytest.approx((200.0 - 2.25, 0.0))


def _wedged_truck(sumo: SumoBridge) -> float:
    """A truck standing at its minGap behind a stopped car in the lane beside, astride the line between (1.2 m over
    it), an external ego standing 1.4 m behind it: SUMO's standstill of incident_in_traffic seed 1311. Returns
    the ego's centre x."""
    import libsumo

    sumo.add_route("r", ["straight"])
    sumo.add_stopped_vehicle("obstacle", "road", "obstacle", edge_id="straight", lane_index=1, pos_m=200.0)
    sumo.add_external_vehicle("ego", "r", "ego", lane_index=2, pos_m=120.0, speed_mps=0.0)
    front_m = 200.0 - libsumo.vehicle.getLength("obstacle") - 3.0
    sumo.add_vehicle("truck", "road", "truck", lane_index=2, pos_m=front_m, speed_mps=0.0)
    sumo.step()
    libsumo.vehicle.setLaneChangeMode("truck", 0)  # put astride the line, as SUMO's own move at 0 m/s left it
    libsumo.vehicle.changeSublane("truck", -1.7)
    libsumo.vehicle.setSpeed("truck", 0.0)
    for _ in range(75):
        sumo.step()
    libsumo.vehicle.setLaneChangeMode("truck", 1621)
    libsumo.vehicle.setSpeed("truck", -1)
    return front_m - 12.0 - 1.4 - 2.6


def test_a_driver_wedged_astride_a_lane_line_by_a_stopped_car_is_moved_back_into_its_lane():
    import libsumo

    for straighten in (False, True):
        with SumoBridge(NET, [ROUTES], lateral_resolution_m=0.4) as sumo:
            ego_x_m = _wedged_truck(sumo)
            moved = []
            for step in range(500):  # 20 s
                sumo.move_external("ego", ego_x_m, 3.5, 0.0, speed_mps=0.0)
                sumo.step()
                if straighten and step % 25 == 0 and (now := sumo.straighten_wedged(5.0)):
                    assert libsumo.vehicle.getLaneChangeMode("truck") == 0  # SUMO's checks off for the move
                    moved += now
            lateral_m, at_m = libsumo.vehicle.getLateralLanePosition("truck"), libsumo.vehicle.getLanePosition("truck")
            if straighten:  # moved once, after 5 s standing; back in its lane, past the car, its own mode back
                assert moved == ["truck"]
                assert abs(lateral_m) < 0.1 and at_m > 230.0
                assert libsumo.vehicle.getLaneChangeMode("truck") == 1621
            else:  # left to SUMO, it stands astride for good
                assert lateral_m == pytest.approx(-1.7, abs=0.01) and at_m == pytest.approx(192.5)
                assert libsumo.vehicle.getSpeed("truck") == 0.0
