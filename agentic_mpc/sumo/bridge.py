"""The only module that talks to SUMO (through libsumo); everything else sees plain records in our conventions.

Conventions are converted here, at the boundary:

- SUMO places a vehicle by its FRONT-BUMPER centre, our model by its centre: they differ by half the
  vehicle length along the heading;
- SUMO's angle is navigational (degrees, 0 = north, clockwise), ours is mathematical (radians, 0 = +x,
  counter-clockwise): ``angle_deg = 90 - degrees(phi)``;
- our lateral offsets are + to the left; SUMO's are + to the RIGHT in left-hand nets (its cars, measured), but
  ``moveToXY`` stores a point left of the lane as + there too: in left-hand nets reads are negated and
  ``moveToXY`` gets the point mirrored across its lane's centre line (the shift is added back on reading).

libsumo runs one simulation per process, and a second ``libsumo.start`` silently replaces the first: this
module refuses to start a second one (:class:`SumoAlreadyRunningError`). Run several simulations in
several processes. Two measured traps are handled here: a malformed net file crashes libsumo (the whole
process), so the net is parsed before SUMO sees it; and ``moveToXY`` on a vehicle that is not yet inserted
can crash too, so an externally driven vehicle is inserted by a simulation step first.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable, Sequence
from pathlib import Path

import libsumo
from libsumo import constants as tc

from agentic_mpc.sumo.options import declares_lefthand, sumo_command
from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import (
    CollisionRecord,
    SumoError,
    VehicleInfo,
    VehicleState,
    centre_to_front,
    check_net_file,
    front_to_centre,
)

__all__ = [
    "CollisionRecord",
    "SumoAlreadyRunningError",
    "SumoBridge",
    "SumoError",
    "VehicleInfo",
    "VehicleState",
    "centre_to_front",
    "check_net_file",
    "front_to_centre",
]

_LIBSUMO_ERRORS = (libsumo.TraCIException, libsumo.FatalTraCIError)

# Read for every vehicle in range every step: plain ints (not ``tc.`` lookups) for the per-vehicle conversion.
_POSITION, _ANGLE, _SPEED, _LANE_ID, _LANE_INDEX, _LANE_POS, _LANE_POS_LAT = _STATE_VARIABLES = (
    tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED, tc.VAR_LANE_ID, tc.VAR_LANE_INDEX, tc.VAR_LANEPOSITION,
    tc.VAR_LANEPOSITION_LAT,
)
_SUMO_LANE_CHANGE_MODE = 1621  # SUMO's default lane-change mode (every kind of change, respecting others)
_GAP_CHANGE_RATE = 1.0  # openGap: how fast the follower's headway moves to the requested one (per s)
_new_state = tuple.__new__  # VehicleState without the NamedTuple's keyword-handling __new__ (half the cost)

_active_lock = threading.Lock()
_active: SumoBridge | None = None


class SumoAlreadyRunningError(SumoError):
    """A second simulation in one process: libsumo would silently replace the first."""


class SumoBridge:
    """One running SUMO simulation (libsumo), started on construction; use as a context manager.

    ``lateral_resolution_m`` switches the sublane model on (e.g. 0.4): other drivers then react to lateral
    positions inside lanes (rescue lanes, a half-changed ego), at about 10x the cost per step.

    ``keep_route`` is moveToXY's keepRoute for the external vehicle. 3 (exact position, lane matched on the
    vehicle's route only) rather than 2 (exact position, lane matched anywhere): with 2, SUMO 1.28 left the
    ego off every lane (lane '', speed garbage) at a point 3 cm past a junction's internal lane on the curvy
    road, although it lay on the road; 3 mapped the same point to the internal lane (measured). Off the
    road both behave alike: lane '' and other traffic ignores the vehicle.
    """

    def __init__(
        self,
        net_file: str | Path,
        route_files: Sequence[str | Path] = (),
        *,
        seed: int = 0,
        step_length_s: float = 0.04,
        lateral_resolution_m: float | None = None,
        log_file: str | Path | None = None,
        quiet: bool = True,
        keep_route: int = 3,
        bluelight_reaction_dist_m: float | None = None,
        lefthand: bool | None = None,
        extra_options: Sequence[str] = (),
    ) -> None:
        global _active
        self.net_file = Path(net_file)
        self.route_files = tuple(Path(r) for r in route_files)
        self.step_length_s = step_length_s
        self._running = False
        self._info: dict[str, VehicleInfo] = {}
        self._context_ego: str | None = None
        self._emergency: set[str] = set()
        self._stopped: set[str] = set()  # obstacles held by a stop
        self._external: dict[str, float] = {}  # id -> length, for the centre/front conversion
        self._pending_speeds: dict[str, tuple[float, float]] = {}
        self._waiting_external: dict[str, tuple[int, float]] = {}
        self._speed_overrides: dict[str, float] = {}
        self._mirror_shift: dict[str, tuple[float, float]] = {}  # see move_external
        self.keep_route = keep_route
        self.collisions: tuple[CollisionRecord, ...] = ()
        """Collisions SUMO reported in the last step."""
        self.departed: tuple[str, ...] = ()
        self.arrived: tuple[str, ...] = ()

        check_net_file(self.net_file)
        for route_file in self.route_files:
            if not route_file.is_file():
                raise SumoError(f"route file not found: {route_file}")
        self.lefthand = declares_lefthand(self.net_file) if lefthand is None else lefthand
        self.command = sumo_command(
            self.net_file, self.route_files, seed=seed, step_length_s=step_length_s,
            lateral_resolution_m=lateral_resolution_m, bluelight_reaction_dist_m=bluelight_reaction_dist_m,
            log_file=log_file, quiet=quiet, extra_options=extra_options,
        )
        command = list(self.command)

        with _active_lock:
            if _active is not None or libsumo.simulation.isLoaded():
                raise SumoAlreadyRunningError(
                    "a SUMO simulation is already running in this process (libsumo runs one per process and a"
                    " second start would silently replace it): close it first, or run this one in another process"
                )
            try:
                libsumo.start(list(command))
            except _LIBSUMO_ERRORS as error:
                if libsumo.simulation.isLoaded():  # a start that failed half-way (e.g. in a route file)
                    try:
                        libsumo.close()
                    except _LIBSUMO_ERRORS:
                        pass
                raise SumoError(
                    f"SUMO refused to start with net {self.net_file} and routes {[str(r) for r in self.route_files]}:"
                    f" {_message(error)}"
                ) from error
            _active = self
            self._running = True

    # --- lifecycle -----------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._running

    def close(self) -> None:
        """Close SUMO (idempotent); afterwards another simulation may start in this process."""
        global _active
        with _active_lock:
            if not self._running:
                return
            self._running = False
            if _active is self:
                _active = None
            try:
                libsumo.close()
            except _LIBSUMO_ERRORS:
                pass  # already closed by SUMO itself (a fatal error): nothing left to release

    def __enter__(self) -> SumoBridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _require_running(self) -> None:
        if not self._running:
            raise SumoError("the SUMO simulation is closed")

    def _fail(self, what: str, error: BaseException) -> SumoError:
        """Close SUMO after a failed command and describe the failure (time, command, SUMO's message)."""
        time_s = self._time_or_nan()
        self.close()
        return SumoError(f"SUMO failed at t={time_s:.2f} s while {what}: {_message(error)}")

    def _time_or_nan(self) -> float:
        try:
            return libsumo.simulation.getTime()
        except _LIBSUMO_ERRORS:
            return float("nan")

    # --- time ----------------------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        self._require_running()
        return libsumo.simulation.getTime()

    def step(self) -> None:
        """Advance SUMO by one step; afterwards ``collisions``, ``departed`` and ``arrived`` describe it."""
        self._require_running()
        try:
            libsumo.simulation.step()
            # Subscription results were taken inside the step: they still show SUMO's own speed, so the
            # override is remembered and applied to what the readers below return. (Plain loops: right after
            # SUMO's step every line runs with cold caches, and comprehensions cost a function call each.)
            overrides = {}
            for vehicle_id, (speed, accel) in self._pending_speeds.items():
                libsumo.vehicle.setPreviousSpeed(vehicle_id, speed, accel)
                overrides[vehicle_id] = speed
            self._speed_overrides = overrides
            self._pending_speeds.clear()
            collisions = libsumo.simulation.getCollisions()
            self.collisions = tuple(
                CollisionRecord(
                    c.collider, c.victim, c.colliderType, c.victimType, c.colliderSpeed, c.victimSpeed,
                    c.type, c.lane, c.pos,
                )
                for c in collisions
            ) if collisions else ()
            self.departed = tuple(libsumo.simulation.getDepartedIDList())
            self.arrived = tuple(libsumo.simulation.getArrivedIDList())
            for vehicle_id in self.departed:
                if self.info(vehicle_id).vclass == "emergency":
                    libsumo.vehicle.subscribe(vehicle_id, _STATE_VARIABLES)
                    self._emergency.add(vehicle_id)
            self._emergency.difference_update(self.arrived)
        except _LIBSUMO_ERRORS as error:
            raise self._fail("stepping the simulation", error) from error

    # --- adding vehicles -----------------------------------------------------------------------------
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
            libsumo.vehicle.setSpeedMode(vehicle_id, 0)
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

    # --- driving the external vehicle ------------------------------------------------------------------
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

    def release_rescue_lanes(self, behind_m: float, lc_strategic: dict[str, float]) -> tuple[str, ...]:
        """Drivers an emergency vehicle has passed by more than ``behind_m`` (along their route) get strategic lane
        changes (``lc_strategic``: vType id -> lcStrategic, else SUMO's 1) and SUMO's default lane-change mode
        back; SUMO's bluelight device keeps both from them while it is on their edge (docs/traffic.md). External
        and stopped vehicles are left alone. Returns the ids released."""
        self._require_running()
        released = []
        try:
            for vehicle_id in libsumo.vehicle.getIDList():
                emergency_id = libsumo.vehicle.getParameter(vehicle_id, "rescueLane")
                if not emergency_id or vehicle_id in self._external or vehicle_id in self._stopped:
                    continue
                if float(libsumo.vehicle.getParameter(vehicle_id, "laneChangeModel.lcStrategic")) >= 0.0:
                    continue  # released already (the device takes it once)
                if emergency_id in self._emergency:
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

    def lane_vehicles(self, lane_id: str) -> list[tuple[float, float, float, float]]:
        """(front-bumper lane position, length, minGap, speed) of each vehicle on a lane, by position."""
        self._require_running()
        v = libsumo.vehicle
        try:
            return sorted((v.getLanePosition(i), v.getLength(i), v.getMinGap(i), v.getSpeed(i))
                          for i in libsumo.lane.getLastStepVehicleIDs(lane_id))
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot read the vehicles on lane {lane_id!r}: {_message(error)}") from error

    # --- reading -------------------------------------------------------------------------------------
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
            return _new_state(VehicleState, (vehicle_id, x, y, phi, speed, "", -1, math.nan, math.nan))
        lateral = values[_LANE_POS_LAT]
        return _new_state(VehicleState, (vehicle_id, x, y, phi, speed, lane_id, values[_LANE_INDEX],
                                         values[_LANE_POS], -lateral if self.lefthand else lateral))

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
            else:
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

