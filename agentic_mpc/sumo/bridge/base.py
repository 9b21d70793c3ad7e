"""What the bridge's parts share: libsumo's errors, the subscribed variables, and the state every part reads."""

from __future__ import annotations

import libsumo
from libsumo import constants as tc

from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import SumoError, VehicleInfo
from agentic_mpc.world.observation import CollisionObservation

_LIBSUMO_ERRORS = (libsumo.TraCIException, libsumo.FatalTraCIError)

# Read for every vehicle in range every step: plain ints (not ``tc.`` lookups) for the per-vehicle conversion.
_POSITION, _ANGLE, _SPEED, _LANE_ID, _LANE_INDEX, _LANE_POS, _LANE_POS_LAT, _ROUTE_INDEX, _ACCELERATION = (
    _STATE_VARIABLES
) = (
    tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED, tc.VAR_LANE_ID, tc.VAR_LANE_INDEX, tc.VAR_LANEPOSITION,
    tc.VAR_LANEPOSITION_LAT, tc.VAR_ROUTE_INDEX, tc.VAR_ACCELERATION,
)


class BridgeState:
    """The running simulation's bookkeeping (set up by :class:`~agentic_mpc.sumo.bridge.SumoBridge`, which also
    has ``close``, ``step``, ``time_s`` and ``info``) and the failure handling every command shares."""

    lefthand: bool
    keep_route: int
    _running: bool
    _info: dict[str, VehicleInfo]
    _context_ego: str | None
    _emergency: set[str]
    _stopped: set[str]  # obstacles held by a stop
    _straightening: dict[str, tuple[int, float]]  # wedged drivers moved back -> (own lane-change mode, until s)
    _external: dict[str, float]  # id -> length, for the centre/front conversion
    _pending_speeds: dict[str, tuple[float, float]]
    _waiting_external: dict[str, tuple[int, float]]
    _speed_overrides: dict[str, float]
    _mirror_shift: dict[str, tuple[float, float]]  # see move_external
    _outlines: dict[str, tuple[float, float]]  # shown outline id -> its (length, width) in SUMO (show_outline)
    _routes: dict[str, tuple[int, tuple[str, ...]]]  # id -> (the route index it was read at, its route's edges)
    collisions: tuple[CollisionObservation, ...]
    departed: tuple[str, ...]
    arrived: tuple[str, ...]

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
