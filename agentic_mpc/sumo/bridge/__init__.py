"""The only package that talks to SUMO (through libsumo); everything else sees plain records in our conventions.

Conventions are converted here, at the boundary:

- SUMO places a vehicle by its FRONT-BUMPER centre, our model by its centre: they differ by half the
  vehicle length along the heading;
- SUMO's angle is navigational (degrees, 0 = north, clockwise), ours is mathematical (radians, 0 = +x,
  counter-clockwise): ``angle_deg = 90 - degrees(phi)``;
- our lateral offsets are + to the left; SUMO's are + to the RIGHT in left-hand nets (its cars, measured), but
  ``moveToXY`` stores a point left of the lane as + there too: in left-hand nets reads are negated and
  ``moveToXY`` gets the point mirrored across its lane's centre line (the shift is added back on reading).

libsumo runs one simulation per process, and a second ``libsumo.start`` silently replaces the first: this
package refuses to start a second one (:class:`SumoAlreadyRunningError`). Run several simulations in
several processes. Two measured traps are handled here: a malformed net file crashes libsumo (the whole
process), so the net is parsed before SUMO sees it; and ``moveToXY`` on a vehicle that is not yet inserted
can crash too, so an externally driven vehicle is inserted by a simulation step first.

One part per job: :mod:`.vehicles` (adding
vehicles, driving the external one), :mod:`.drivers` (what SUMO's drivers are told), :mod:`.reading` (states in
our conventions), :mod:`.signals` (traffic lights, a junction's foes); here the simulation's start, step and end.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Self

import libsumo

from agentic_mpc.sumo.bridge.base import _LIBSUMO_ERRORS, _STATE_VARIABLES
from agentic_mpc.sumo.bridge.drivers import DriverCommands
from agentic_mpc.sumo.bridge.reading import Reading
from agentic_mpc.sumo.bridge.signals import SignalReading
from agentic_mpc.sumo.bridge.vehicles import VehicleCommands
from agentic_mpc.sumo.options import declares_lefthand, sumo_command
from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import (
    SumoError,
    VehicleInfo,
    VehicleState,
    centre_to_front,
    check_net_file,
    front_to_centre,
)
from agentic_mpc.world.observation import CollisionObservation

__all__ = [
    "SumoAlreadyRunningError",
    "SumoBridge",
    "SumoError",
    "VehicleInfo",
    "VehicleState",
    "centre_to_front",
    "check_net_file",
    "front_to_centre",
]

_active_lock = threading.Lock()
_active: SumoBridge | None = None


class SumoAlreadyRunningError(SumoError):
    """A second simulation in one process: libsumo would silently replace the first."""


class SumoBridge(VehicleCommands, DriverCommands, Reading, SignalReading):
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
        self._straightening: dict[str, tuple[int, float]] = {}  # wedged drivers moved -> (own lc mode, until s)
        self._external: dict[str, float] = {}  # id -> length, for the centre/front conversion
        self._pending_speeds: dict[str, tuple[float, float]] = {}
        self._waiting_external: dict[str, tuple[int, float]] = {}
        self._speed_overrides: dict[str, float] = {}
        self._mirror_shift: dict[str, tuple[float, float]] = {}  # see move_external
        self._outlines: dict[str, tuple[float, float]] = {}  # shown outline id -> (length, width) (show_outline)
        self._routes: dict[str, tuple[int, tuple[str, ...]]] = {}
        self.keep_route = keep_route
        self.collisions: tuple[CollisionObservation, ...] = ()
        """Collisions SUMO reported in the last step (the observation's fills in the ego's part)."""
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

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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
                CollisionObservation(
                    c.collider, c.victim, c.colliderType, c.victimType, c.colliderSpeed, c.victimSpeed,
                    c.type, c.lane, c.pos, False, "sumo", math.nan,
                )
                for c in collisions
                if c.collider not in self._outlines and c.victim not in self._outlines
            ) if collisions else ()
            self.departed = tuple(libsumo.simulation.getDepartedIDList())
            self.arrived = tuple(libsumo.simulation.getArrivedIDList())
            for vehicle_id in self.departed:
                if self.info(vehicle_id).vclass == "emergency":
                    libsumo.vehicle.subscribe(vehicle_id, _STATE_VARIABLES)
                    self._emergency.add(vehicle_id)
            self._emergency.difference_update(self.arrived)
            for vehicle_id in self.arrived:  # an outline moved past its route's end: shown anew where needed
                self._outlines.pop(vehicle_id, None)
                self._routes.pop(vehicle_id, None)
        except _LIBSUMO_ERRORS as error:
            raise self._fail("stepping the simulation", error) from error
