"""Putting vehicles into SUMO and driving the external one (the ego) by ``moveToXY``."""

from __future__ import annotations

import math
from collections.abc import Iterable

import libsumo
from libsumo import constants as tc

from agentic_mpc.sumo.bridge.base import _LIBSUMO_ERRORS, BridgeState
from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import SumoError, centre_to_front

_RESIZE_M = 0.05  # the outline is resized in SUMO when its length or width changes by more than this
EXTERNAL_SPEED_MODE = 0
"""SUMO's speed mode for the external vehicle: none of its own checks (our model drives it). SUMO's junction logic
then takes it to pass every link ahead, red lights included (``MSVehicle::ignoreRed`` is true without bit 4)."""
STOPPING_AT_LIGHT_SPEED_MODE = 16
"""... and while it stops at a red or yellow light (:meth:`VehicleCommands.stop_external_at_light`): bit 4, "brake
hard to avoid passing a red light", so that SUMO registers it at the links behind that light as one that will not
pass. Registered as passing, an ego standing at its red light held the oncoming left turners that had gone into an
OpenStreetMap cluster on their green: they waited inside it, at their crossing with the ego's movement, and were
still there, in its way, when its light turned green; the ego stood behind them and they waited for it, for good
(``junction_osm_route`` seed 303, t = 300 s: osm19.2 had waited there 26 s; docs/networks.md). Only while it stops:
SUMO decides a yellow with the vType's decel, the ego with its own rule, and an ego going through a yellow that
SUMO took to stop would have the left turners turn in front of it."""


class VehicleCommands(BridgeState):
    """Routes, SUMO-driven, stopped and external vehicles; the external vehicle's pose each step."""

    def add_route(self, route_id: str, edge_ids: Iterable[str]) -> None:
        self._require_running()
        try:
            libsumo.route.add(route_id, list(edge_ids))
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot add route {route_id!r} ({list(edge_ids)}): {_message(error)}") from error

    def add_vehicle(
        self,
        vehicle_id: str,
        route_id: str,
        type_id: str,
        *,
        lane_index: int,
        pos_m: float,
        speed_mps: float,
        depart_s: float | None = None,
    ) -> None:
        """Add a SUMO-driven vehicle; it is inserted at ``depart_s`` (now if None) when SUMO finds room."""
        self._require_running()
        try:
            libsumo.vehicle.add(
                vehicle_id,
                route_id,
                typeID=type_id,
                depart="now" if depart_s is None else repr(float(depart_s)),
                departLane=str(lane_index),
                departPos=repr(float(pos_m)),
                departSpeed=repr(float(speed_mps)),
            )
        except _LIBSUMO_ERRORS as error:
            raise SumoError(
                f"cannot add vehicle {vehicle_id!r} (type {type_id!r}, route {route_id!r}, lane {lane_index},"
                f" pos {pos_m} m): {_message(error)}"
            ) from error

    def configure_vehicle(
        self,
        vehicle_id: str,
        *,
        max_speed_mps: float | None = None,
        speed_factor: float | None = None,
        imperfection: float | None = None,
        lane_change_mode: int | None = None,
    ) -> None:
        """Per-vehicle overrides of its type (works before insertion too)."""
        self._require_running()
        try:
            if max_speed_mps is not None:
                libsumo.vehicle.setMaxSpeed(vehicle_id, max_speed_mps)
            if speed_factor is not None:
                libsumo.vehicle.setSpeedFactor(vehicle_id, speed_factor)
            if imperfection is not None:
                libsumo.vehicle.setImperfection(vehicle_id, imperfection)
            if lane_change_mode is not None:
                libsumo.vehicle.setLaneChangeMode(vehicle_id, lane_change_mode)
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot configure vehicle {vehicle_id!r}: {_message(error)}") from error

    def add_stopped_vehicle(
        self, vehicle_id: str, route_id: str, type_id: str, *, edge_id: str, lane_index: int, pos_m: float
    ) -> None:
        """A vehicle that stands at ``pos_m`` (front bumper) for good: an obstacle SUMO traffic respects.

        A stop on the lane (not a parking stop, which leaves the lane; not speed 0, which gets teleported).
        """
        self.add_vehicle(vehicle_id, route_id, type_id, lane_index=lane_index, pos_m=pos_m, speed_mps=0.0)
        self._stopped.add(vehicle_id)
        try:
            libsumo.vehicle.setLaneChangeMode(vehicle_id, 0)
            libsumo.vehicle.setStop(vehicle_id, edge_id, pos=pos_m, laneIndex=lane_index, duration=1e9)
        except _LIBSUMO_ERRORS as error:
            raise SumoError(
                f"cannot stop obstacle {vehicle_id!r} on {edge_id!r} lane {lane_index} at {pos_m} m: {_message(error)}"
            ) from error

    def add_external_vehicle(
        self,
        vehicle_id: str,
        route_id: str,
        type_id: str,
        *,
        lane_index: int,
        pos_m: float,
        speed_mps: float,
        wait: bool = True,
        max_wait_steps: int = 250,
    ) -> int:
        """Add a vehicle we drive (moveToXY); with ``wait``, step until SUMO has inserted it (returns the steps).

        SUMO's own speed and lane-change control are switched off for it. Inserting first matters:
        ``moveToXY`` on a vehicle not yet inserted can crash libsumo. Without ``wait``, add other vehicles
        and then call :meth:`wait_until_inserted`: SUMO inserts in the order vehicles were added.
        """
        self.add_vehicle(vehicle_id, route_id, type_id, lane_index=lane_index, pos_m=pos_m, speed_mps=speed_mps)
        try:
            libsumo.vehicle.setSpeedMode(vehicle_id, EXTERNAL_SPEED_MODE)
            libsumo.vehicle.setLaneChangeMode(vehicle_id, 0)
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot configure the external vehicle {vehicle_id!r}: {_message(error)}") from error
        self._waiting_external[vehicle_id] = (lane_index, pos_m)
        return self.wait_until_inserted(vehicle_id, max_wait_steps) if wait else 0

    def wait_until_inserted(self, vehicle_id: str, max_wait_steps: int = 250, *, withdraw: bool = False) -> int | None:
        """Step until SUMO has inserted the external vehicle ``vehicle_id``; returns the steps taken. Not in
        time: with ``withdraw`` it is removed and None returned (SUMO runs on), else SUMO closes, SumoError."""
        lane_index, pos_m = self._waiting_external.pop(vehicle_id)
        for steps in range(1, max_wait_steps + 1):
            self.step()
            if vehicle_id in self.departed or vehicle_id in libsumo.vehicle.getIDList():
                self._external[vehicle_id] = self.info(vehicle_id).length_m
                return steps
        if withdraw:
            self.remove_vehicle(vehicle_id)
            return None
        time_s = self.time_s
        self.close()
        raise SumoError(
            f"SUMO did not insert {vehicle_id!r} on lane {lane_index} at {pos_m} m within {max_wait_steps} steps"
            f" (t={time_s:.2f} s): the spot is occupied or the position is not on its route's first edge"
        )

    def remove_vehicle(self, vehicle_id: str) -> None:
        self._require_running()
        try:
            libsumo.vehicle.remove(vehicle_id)
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot remove vehicle {vehicle_id!r}: {_message(error)}") from error

    def set_route(self, vehicle_id: str, edge_ids: Iterable[str]) -> None:
        """Give a vehicle a new route: ``edge_ids`` from the route edge it is on now (inside a junction, the one it
        came from) onwards, so that SUMO's drivers see where it goes."""
        self._require_running()
        edges = list(edge_ids)
        try:
            route = libsumo.vehicle.getRoute(vehicle_id)
            current = route[libsumo.vehicle.getRouteIndex(vehicle_id)]
            libsumo.vehicle.setRoute(vehicle_id, edges[edges.index(current):] if current in edges else edges)
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot give {vehicle_id!r} the route {edges}: {_message(error)}") from error

    # --- driving the external vehicle ------------------------------------------------------------------
    def stop_external_at_light(self, vehicle_id: str, stopping: bool) -> None:
        """Tell SUMO's junction logic whether our vehicle stops at the red or yellow light ahead (it then registers
        it at the links behind the light as not passing: :data:`STOPPING_AT_LIGHT_SPEED_MODE`) or drives on."""
        try:
            libsumo.vehicle.setSpeedMode(vehicle_id, STOPPING_AT_LIGHT_SPEED_MODE if stopping else EXTERNAL_SPEED_MODE)
        except _LIBSUMO_ERRORS as error:
            raise self._fail(f"telling SUMO whether {vehicle_id!r} stops at a light", error) from error

    def let_go_first(self, vehicle_id: str, ego_id: str, first: bool = True) -> None:
        """Tell SUMO's driver of ``vehicle_id`` to stop giving way to ``ego_id`` at junctions (``first``), or to
        give way again. A vehicle that has left the simulation is not told (nothing is left to tell)."""
        try:
            libsumo.vehicle.setParameter(vehicle_id, "junctionModel.ignoreIDs", ego_id if first else "")
        except _LIBSUMO_ERRORS as error:
            if vehicle_id in libsumo.vehicle.getIDList():
                raise self._fail(f"telling {vehicle_id!r} to go before {ego_id!r}", error) from error

    def move_external(
        self, vehicle_id: str, x_m: float, y_m: float, phi_rad: float, speed_mps: float | None = None,
        accel_mps2: float | None = None,
    ) -> None:
        """Place our vehicle's centre pose for the next step (x, y kept exactly; SUMO maps the lane).

        ``speed_mps``: our model's speed, written into SUMO after the step. Otherwise SUMO's speed is the
        displacement over the step, capped at the lane's speed limit times the vehicle's speed factor
        (measured), and followers would see a wrong leader speed whenever the ego is faster than that.
        """
        length = self._external.get(vehicle_id)
        if length is None:
            raise SumoError(f"{vehicle_id!r} was not added with add_external_vehicle")
        x_front, y_front, angle = centre_to_front(x_m, y_m, phi_rad, length)
        try:
            x_sumo, y_sumo = self._mirrored(x_front, y_front) if self.lefthand else (x_front, y_front)
            libsumo.vehicle.moveToXY(vehicle_id, "", -1, x_sumo, y_sumo, angle, keepRoute=self.keep_route)
            self._mirror_shift[vehicle_id] = (x_front - x_sumo, y_front - y_sumo)
        except _LIBSUMO_ERRORS as error:
            raise self._fail(f"moving {vehicle_id!r} to ({x_m:.2f}, {y_m:.2f})", error) from error
        if speed_mps is not None:
            accel = tc.INVALID_DOUBLE_VALUE if accel_mps2 is None else accel_mps2
            self._pending_speeds[vehicle_id] = (speed_mps, accel)

    # --- the external vehicle's outline ---------------------------------------------------------------
    def show_outline(self, outline_id: str, route_id: str, type_id: str, *, x_m: float, y_m: float, phi_rad: float,
                     length_m: float, width_m: float, speed_mps: float) -> None:
        """A vehicle of ``length_m`` x ``width_m`` centred at (x, y), heading ``phi_rad``, moving at ``speed_mps``:
        the part of the external vehicle that sticks into a lane it is not in (``agentic_mpc.sumo.outline``).
        Added where it is first shown (``moveToXY`` inserts a vehicle SUMO has not inserted yet, on the road),
        resized as it changes; left out of :meth:`around` and :attr:`collisions`."""
        x_front, y_front, angle = centre_to_front(x_m, y_m, phi_rad, length_m)
        shown = self._outlines.get(outline_id)
        try:
            if shown is None:
                libsumo.vehicle.add(outline_id, route_id, typeID=type_id, depart="now", departSpeed="0")
                libsumo.vehicle.setSpeedMode(outline_id, 0)
                libsumo.vehicle.setLaneChangeMode(outline_id, 0)
            if shown is None or abs(shown[0] - length_m) > _RESIZE_M or abs(shown[1] - width_m) > _RESIZE_M:
                libsumo.vehicle.setLength(outline_id, length_m)
                libsumo.vehicle.setWidth(outline_id, width_m)
                self._outlines[outline_id] = (length_m, width_m)
            x_sumo, y_sumo = self._mirrored(x_front, y_front) if self.lefthand else (x_front, y_front)
            libsumo.vehicle.moveToXY(outline_id, "", -1, x_sumo, y_sumo, angle, keepRoute=2)
        except _LIBSUMO_ERRORS as error:
            raise self._fail(f"showing {outline_id!r} at ({x_m:.2f}, {y_m:.2f})", error) from error
        if shown is not None:  # inserted in an earlier step: SUMO's speed is then ours, as the external vehicle's
            self._pending_speeds[outline_id] = (speed_mps, tc.INVALID_DOUBLE_VALUE)

    def hide_outline(self, outline_id: str) -> None:
        """Remove the outline shown by :meth:`show_outline` (nothing if it is not shown)."""
        if self._outlines.pop(outline_id, None) is not None:
            self._pending_speeds.pop(outline_id, None)
            if outline_id in libsumo.vehicle.getIDList():  # not if SUMO removed it (at its route's end)
                self.remove_vehicle(outline_id)

    def _mirrored(self, x_m: float, y_m: float) -> tuple[float, float]:
        """The point mirrored across the centre line of its lane (itself off every lane); see the module doc."""
        try:
            edge_id, pos, lane_index = libsumo.simulation.convertRoad(x_m, y_m)
        except _LIBSUMO_ERRORS:  # far from every lane: nothing to mirror
            return x_m, y_m
        x_centre, y_centre = libsumo.simulation.convert2D(edge_id, pos, lane_index)
        if math.hypot(x_m - x_centre, y_m - y_centre) > 0.5 * libsumo.lane.getWidth(f"{edge_id}_{lane_index}"):
            return x_m, y_m  # off the lane: SUMO leaves it off every lane either way
        return 2.0 * x_centre - x_m, 2.0 * y_centre - y_m
