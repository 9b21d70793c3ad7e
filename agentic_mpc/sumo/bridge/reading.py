"""Reading SUMO: vehicles' sizes and states in our conventions, the subscriptions, SUMO's own leaders."""

from __future__ import annotations

import math

import libsumo
from libsumo import constants as tc

from agentic_mpc.sumo.bridge.base import (
    _ACCELERATION,
    _ANGLE,
    _LANE_ID,
    _LANE_INDEX,
    _LANE_POS,
    _LANE_POS_LAT,
    _LIBSUMO_ERRORS,
    _POSITION,
    _ROUTE_INDEX,
    _SPEED,
    _STATE_VARIABLES,
    BridgeState,
)
from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import SumoError, VehicleInfo, VehicleState, front_to_centre

_new_state = tuple.__new__  # VehicleState without the NamedTuple's keyword-handling __new__ (half the cost)


class Reading(BridgeState):
    """Everything read back from SUMO."""

    def lane_vehicles(self, lane_id: str) -> list[tuple[float, float, float, float]]:
        """(front-bumper lane position, length, minGap, speed) of each vehicle on a lane, by position."""
        self._require_running()
        v = libsumo.vehicle
        try:
            return sorted((v.getLanePosition(i), v.getLength(i), v.getMinGap(i), v.getSpeed(i))
                          for i in libsumo.lane.getLastStepVehicleIDs(lane_id))
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot read the vehicles on lane {lane_id!r}: {_message(error)}") from error

    def info(self, vehicle_id: str) -> VehicleInfo:
        """Type, class and size of a vehicle (read once, then cached)."""
        cached = self._info.get(vehicle_id)
        if cached is None:
            try:
                v = libsumo.vehicle
                cached = VehicleInfo(
                    v.getTypeID(vehicle_id), v.getVehicleClass(vehicle_id), v.getLength(vehicle_id),
                    v.getWidth(vehicle_id),
                )
            except _LIBSUMO_ERRORS as error:
                raise SumoError(f"cannot read vehicle {vehicle_id!r}: {_message(error)}") from error
            self._info[vehicle_id] = cached
        return cached

    def _state(self, vehicle_id: str, values: dict) -> VehicleState:
        x_front, y_front = values[_POSITION]
        shift = self._mirror_shift.get(vehicle_id)
        if shift is not None:
            x_front, y_front = x_front + shift[0], y_front + shift[1]
        info = self._info.get(vehicle_id) or self.info(vehicle_id)
        x, y, phi = front_to_centre(x_front, y_front, values[_ANGLE], info.length_m)
        lane_id = values[_LANE_ID]
        speed = self._speed_overrides.get(vehicle_id, values[_SPEED])
        if not lane_id:  # off every lane: SUMO reports INVALID_DOUBLE/INT for the lane quantities
            return _new_state(VehicleState, (vehicle_id, x, y, phi, speed, "", -1, math.nan, math.nan, "",
                                             values[_ACCELERATION]))
        lateral = values[_LANE_POS_LAT]
        return _new_state(VehicleState, (vehicle_id, x, y, phi, speed, lane_id, values[_LANE_INDEX],
                                         values[_LANE_POS], -lateral if self.lefthand else lateral,
                                         self._next_edge(vehicle_id, values[_ROUTE_INDEX]), values[_ACCELERATION]))

    def _next_edge(self, vehicle_id: str, route_index: int) -> str:
        """The edge after ``route_index`` on the vehicle's route. The route is read again only when the index
        moves on (once per edge: SUMO keeps the index on the edge before a junction while it crosses)."""
        cached = self._routes.get(vehicle_id)
        if cached is None or cached[0] != route_index:
            try:
                cached = self._routes[vehicle_id] = (route_index, tuple(libsumo.vehicle.getRoute(vehicle_id)))
            except _LIBSUMO_ERRORS as error:
                raise SumoError(f"cannot read the route of {vehicle_id!r}: {_message(error)}") from error
        route = cached[1]
        return route[route_index + 1] if 0 <= route_index < len(route) - 1 else ""

    def vehicle_state(self, vehicle_id: str) -> VehicleState:
        """One vehicle's state by individual getters (for anything not subscribed)."""
        self._require_running()
        v = libsumo.vehicle
        try:
            values = {
                _POSITION: v.getPosition(vehicle_id),
                _ANGLE: v.getAngle(vehicle_id),
                _SPEED: v.getSpeed(vehicle_id),
                _LANE_ID: v.getLaneID(vehicle_id),
                _LANE_INDEX: v.getLaneIndex(vehicle_id),
                _LANE_POS: v.getLanePosition(vehicle_id),
                _LANE_POS_LAT: v.getLateralLanePosition(vehicle_id),
                _ROUTE_INDEX: v.getRouteIndex(vehicle_id),
                _ACCELERATION: v.getAcceleration(vehicle_id),
            }
        except _LIBSUMO_ERRORS as error:
            raise SumoError(
                f"cannot read vehicle {vehicle_id!r} at t={self._time_or_nan():.2f} s: {_message(error)}"
            ) from error
        return self._state(vehicle_id, values)

    def subscribe_around(self, ego_id: str, range_m: float) -> None:
        """Subscribe to every vehicle within ``range_m`` of ``ego_id`` (read with :meth:`around`)."""
        self._require_running()
        try:
            libsumo.vehicle.subscribeContext(ego_id, tc.CMD_GET_VEHICLE_VARIABLE, range_m, _STATE_VARIABLES)
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot subscribe around {ego_id!r}: {_message(error)}") from error
        self._context_ego = ego_id

    def around(self) -> tuple[VehicleState | None, list[VehicleState]]:
        """(the subscribed ego, the other vehicles within range) as of the last step.

        The ego is None if SUMO no longer has it (it reached its route's end, or was removed).
        """
        if self._context_ego is None:
            raise SumoError("call subscribe_around first")
        ego_id, state = self._context_ego, self._state
        ego = None
        others = []
        for vehicle_id, values in libsumo.vehicle.getContextSubscriptionResults(ego_id).items():
            if vehicle_id == ego_id:
                ego = state(vehicle_id, values)
            elif vehicle_id not in self._outlines:  # the ego's own protruding part (show_outline)
                others.append(state(vehicle_id, values))
        if ego is None and self._context_ego in libsumo.vehicle.getIDList():
            ego = self.vehicle_state(self._context_ego)  # off every lane, SUMO leaves it out of its own context
        return ego, others

    def emergency_vehicles(self) -> list[VehicleState]:
        """Every emergency-class vehicle in the simulation (subscribed when it departs), at any distance."""
        states = []
        for vehicle_id in self._emergency:
            values = libsumo.vehicle.getSubscriptionResults(vehicle_id)
            if values:
                states.append(self._state(vehicle_id, values))
        return states

    def vehicle_ids(self) -> tuple[str, ...]:
        self._require_running()
        return tuple(libsumo.vehicle.getIDList())

    def vehicle_count(self) -> int:
        self._require_running()
        return libsumo.vehicle.getIDCount()

    def has_vehicle(self, vehicle_id: str) -> bool:
        return vehicle_id in self.vehicle_ids()

    def follower(self, vehicle_id: str, distance_m: float = 200.0) -> tuple[str, float] | None:
        """SUMO's follower on the same lane: (id, gap from its front + minGap to our back), or None."""
        self._require_running()
        follower_id, gap = libsumo.vehicle.getFollower(vehicle_id, distance_m)
        return (follower_id, gap) if follower_id else None

    def leader(self, vehicle_id: str, distance_m: float = 200.0) -> tuple[str, float] | None:
        """SUMO's leader on the same lane: (id, gap from our front + minGap to its back), or None."""
        self._require_running()
        found = libsumo.vehicle.getLeader(vehicle_id, distance_m)
        return (found[0], found[1]) if found and found[0] else None

    def min_gap_m(self, vehicle_id: str) -> float:
        return libsumo.vehicle.getMinGap(vehicle_id)

    def convert_2d(self, edge_id: str, pos_m: float, lane_index: int = 0) -> tuple[float, float]:
        """SUMO's own (x, y) of a lane position (``simulation.convert2D``)."""
        self._require_running()
        x, y = libsumo.simulation.convert2D(edge_id, pos_m, lane_index)
        return x, y

    def time_loss_s(self, vehicle_id: str) -> float:
        """SUMO's time loss of a vehicle so far: its travel time minus the time at its ideal speed."""
        self._require_running()
        try:
            return float(libsumo.vehicle.getTimeLoss(vehicle_id))
        except _LIBSUMO_ERRORS as error:
            raise self._fail(f"time loss of {vehicle_id!r}", error) from error
