"""Telling SUMO's drivers things: vType parameters, gaps to open for the ego, release from a rescue lane, a move
back into their lane when wedged astride a line."""

from __future__ import annotations

from collections.abc import Iterable

import libsumo

from agentic_mpc.sumo.bridge.base import _LIBSUMO_ERRORS, BridgeState
from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import SumoError
from agentic_mpc.tactics.queues import QUEUE_STANDING_MPS

_SUMO_LANE_CHANGE_MODE = 1621  # SUMO's default lane-change mode (every kind of change, respecting others)
_GAP_CHANGE_RATE = 1.0  # openGap: how fast the follower's headway moves to the requested one (per s)
STICK_OUT_M = 0.1
"""A driver whose body reaches this far over its lane's line stands astride it (a sublane is 0.4 m wide)."""


class DriverCommands(BridgeState):
    """What SUMO's own drivers are told (the decisions are in ``intention`` and ``world``)."""

    def set_type_parameters(self, type_id: str, params: dict[str, float | str]) -> None:
        """Set generic parameters of a vType (e.g. the bluelight device's reaction probabilities)."""
        try:
            for key, value in params.items():
                libsumo.vehicletype.setParameter(type_id, key, str(value))
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot set parameters {params} of vType {type_id!r}: {_message(error)}") from error

    def open_gaps(self, vehicle_id: str, gap_requests: Iterable, end_for: Iterable[str] = ()) -> None:
        """Each :class:`~agentic_mpc.sumo.intention.GapRequest`'s follower opens a gap behind ``vehicle_id``; the
        vehicles ``end_for`` stop doing so. SUMO's gap control with a reference vehicle ends only once its gap
        is reached: a follower that had passed a standing ego stood for good (measured)."""
        self._require_running()
        try:
            present = set(libsumo.vehicle.getIDList())
            for follower_id in end_for:
                if follower_id in present:
                    libsumo.vehicle.deactivateGapControl(follower_id)
            for request in gap_requests:
                libsumo.vehicle.openGap(
                    request.follower_id, request.time_headway_s, request.space_headway_m, request.duration_s,
                    _GAP_CHANGE_RATE, request.max_decel_mps2, vehicle_id,
                )
        except _LIBSUMO_ERRORS as error:
            raise self._fail(f"asking followers to let {vehicle_id!r} in", error) from error

    def release_rescue_lanes(self, behind_m: float, lc_strategic: dict[str, float],
                             blocked_within_m: float | None = None) -> tuple[str, ...]:
        """Drivers an emergency vehicle has passed by more than ``behind_m`` (along their route) get strategic lane
        changes (``lc_strategic``: vType id -> lcStrategic, else SUMO's 1) and SUMO's default lane-change mode
        back; SUMO's bluelight device keeps both from them while it is on their edge (docs/traffic.md). So do
        drivers standing with a stopped obstacle ahead within ``blocked_within_m`` while the emergency vehicle
        stands too: it cannot pass them, and with both waiting nobody moved (``incident_in_traffic`` seed 901,
        docs/traffic.md). External and stopped vehicles (and outlines) are left alone. Returns the ids released."""
        self._require_running()
        released = []
        try:
            for vehicle_id in libsumo.vehicle.getIDList():
                emergency_id = libsumo.vehicle.getParameter(vehicle_id, "rescueLane")
                if not emergency_id or vehicle_id in self._external or vehicle_id in self._stopped \
                        or vehicle_id in self._outlines:
                    continue
                if float(libsumo.vehicle.getParameter(vehicle_id, "laneChangeModel.lcStrategic")) >= 0.0:
                    continue  # released already (the device takes it once)
                if emergency_id in self._emergency and not self._blocked(vehicle_id, emergency_id, blocked_within_m):
                    x_m, y_m = libsumo.vehicle.getPosition(emergency_id)
                    if libsumo.vehicle.getDrivingDistance2D(vehicle_id, x_m, y_m) <= behind_m:
                        continue  # still close, or not on its route ahead (a huge negative number)
                type_id = libsumo.vehicle.getTypeID(vehicle_id).split("@")[0]  # the device's copy is type@vehicle
                libsumo.vehicle.setParameter(
                    vehicle_id, "laneChangeModel.lcStrategic", repr(lc_strategic.get(type_id, 1.0))
                )
                libsumo.vehicle.setLaneChangeMode(vehicle_id, _SUMO_LANE_CHANGE_MODE)
                released.append(vehicle_id)
        except _LIBSUMO_ERRORS as error:
            raise self._fail("releasing drivers from a rescue lane", error) from error
        return tuple(released)

    def _blocked(self, vehicle_id: str, emergency_id: str, within_m: float | None) -> bool:
        """Whether ``vehicle_id`` and the emergency vehicle it makes way for both stand (< 0.5 m/s), with a stopped
        obstacle its leader within ``within_m``. Released while the emergency vehicle still came up, such drivers
        pulled out into its way (on seeds 900-919 its median delay grew from 34 to 42 s)."""
        if within_m is None or libsumo.vehicle.getSpeed(emergency_id) >= QUEUE_STANDING_MPS:
            return False
        if libsumo.vehicle.getSpeed(vehicle_id) >= QUEUE_STANDING_MPS:
            return False
        leader = libsumo.vehicle.getLeader(vehicle_id, within_m)
        return bool(leader) and leader[0] in self._stopped and leader[1] <= within_m

    def straighten_wedged(self, after_s: float, within_m: float = 0.5, for_s: float = 5.0) -> tuple[str, ...]:
        """Drivers wedged astride a lane line by a stopped obstacle are moved back to their lane's centre.

        Wedged: standing (SUMO's waiting time at least ``after_s``), part of the body over the lane's line
        (``STICK_OUT_M``), and a stopped obstacle in the lane beside ahead within ``within_m``. SUMO's sublane
        model moved such a driver sideways at a standstill and stopped it halfway: its move on was blocked by the
        vehicles behind it, and the obstacle it overlapped was its leader at 0 m, so it and the ego behind it
        stood for good (``incident_in_traffic`` seed 1311, a truck: 80 s; docs/traffic.md). Wedged on any
        standing vehicle beside, drivers in the middle of a zipper merge were moved back too, and the ego had
        more contacts at fault. The move is a ``changeSublane`` with the lane-change mode at 0 (SUMO's checks of
        others off; the move stays inside the driver's own lane) for ``for_s``, then its own mode again.
        External, stopped and emergency vehicles (and outlines) are left alone. Returns the ids moved now."""
        self._require_running()
        moved = []
        try:
            present = set(libsumo.vehicle.getIDList())
            now_s = libsumo.simulation.getTime()
            for vehicle_id, (own_mode, until_s) in list(self._straightening.items()):
                if vehicle_id not in present:
                    del self._straightening[vehicle_id]
                elif now_s >= until_s:
                    libsumo.vehicle.setLaneChangeMode(vehicle_id, own_mode)
                    del self._straightening[vehicle_id]
            ours = self._external.keys() | self._outlines.keys() | self._stopped | self._emergency
            for vehicle_id in sorted(present - ours - self._straightening.keys()):
                if libsumo.vehicle.getWaitingTime(vehicle_id) < after_s:
                    continue
                lateral_m = libsumo.vehicle.getLateralLanePosition(vehicle_id)
                half_lane_m = 0.5 * libsumo.lane.getWidth(libsumo.vehicle.getLaneID(vehicle_id))
                if abs(lateral_m) + 0.5 * libsumo.vehicle.getWidth(vehicle_id) - half_lane_m < STICK_OUT_M \
                        or not self._wedged(vehicle_id, within_m):
                    continue
                self._straightening[vehicle_id] = (libsumo.vehicle.getLaneChangeMode(vehicle_id), now_s + for_s)
                libsumo.vehicle.setLaneChangeMode(vehicle_id, 0)
                libsumo.vehicle.changeSublane(vehicle_id, -lateral_m)
                moved.append(vehicle_id)
        except _LIBSUMO_ERRORS as error:
            raise self._fail("moving wedged drivers back into their lanes", error) from error
        return tuple(moved)

    def _wedged(self, vehicle_id: str, within_m: float) -> bool:
        """Whether a stopped obstacle in a lane beside is ahead of ``vehicle_id`` within ``within_m`` (leaders to
        the right and to the left: getNeighbors modes 3 and 2)."""
        return any(gap_m <= within_m and other in self._stopped
                   for mode in (2, 3) for other, gap_m in libsumo.vehicle.getNeighbors(vehicle_id, mode))
