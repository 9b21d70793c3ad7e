"""What the junctions on the ego's route say: signal states, which movements cross its own, who approaches them."""

from __future__ import annotations

import libsumo

from agentic_mpc.sumo.bridge.base import _LIBSUMO_ERRORS, BridgeState
from agentic_mpc.sumo.options import error_message as _message
from agentic_mpc.sumo.records import SumoError


class SignalReading(BridgeState):
    """Traffic lights and the foes of a junction movement, read from the running simulation."""

    def signal_states(self, tls_ids: tuple[str, ...]) -> dict[str, str]:
        """Each traffic light's state string (one character per link: SUMO's ``rygGsuoO``)."""
        self._require_running()
        try:
            return {tls: libsumo.trafficlight.getRedYellowGreenState(tls) for tls in tls_ids}
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot read the traffic lights {list(tls_ids)}: {_message(error)}") from error

    def internal_foes(self, internal_lane_id: str) -> tuple[str, ...]:
        """The junction's internal lanes whose movements cross (or merge into) this one's."""
        self._require_running()
        try:
            return tuple(libsumo.lane.getInternalFoes(internal_lane_id))
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot read the foes of {internal_lane_id!r}: {_message(error)}") from error

    def approaching(self, lane_id: str, lane_length_m: float) -> list[tuple[str, float, float]]:
        """(vehicle id, distance from its front to the lane's end, speed) of each vehicle on a lane."""
        self._require_running()
        v = libsumo.vehicle
        try:
            return [(i, lane_length_m - v.getLanePosition(i), v.getSpeed(i))
                    for i in libsumo.lane.getLastStepVehicleIDs(lane_id)]
        except _LIBSUMO_ERRORS as error:
            raise SumoError(f"cannot read the vehicles on lane {lane_id!r}: {_message(error)}") from error
