"""Plain records and conventions at the SUMO boundary, free of libsumo (which only ``bridge`` imports).

The pose conversions here are the bridge's: SUMO places a vehicle by its FRONT-BUMPER centre and measures
its angle navigationally (degrees, 0 = north, clockwise); our model uses the centre and a mathematical
heading (radians, 0 = +x, counter-clockwise).
"""

from __future__ import annotations

import math
import xml.sax
from pathlib import Path
from typing import NamedTuple


class SumoError(RuntimeError):
    """SUMO refused to start, rejected a command, or failed during a run."""


class VehicleState(NamedTuple):
    """One vehicle at one step, in our conventions (centre position, heading in rad from +x, CCW)."""

    id: str
    x_m: float
    y_m: float
    heading_rad: float
    speed_mps: float
    lane_id: str
    """'' when SUMO has the vehicle off every lane (an externally moved vehicle off the road)."""
    lane_index: int
    lane_pos_m: float
    """SUMO's lane position of the FRONT bumper (nominal lane length units)."""
    lateral_offset_m: float
    """Offset of the centre from the lane centre (non-zero only with the sublane model or moveToXY)."""
    next_edge_id: str = ""
    """The edge its route takes after the one it is on or leaving ('' at its route's end): the way it will
    leave the junction ahead."""
    accel_mps2: float = 0.0
    """Its acceleration in the last step (negative: braking)."""


class VehicleInfo(NamedTuple):
    """What does not change while a vehicle drives: read once per vehicle."""

    type_id: str
    vclass: str
    length_m: float
    width_m: float


def centre_to_front(x_m: float, y_m: float, phi_rad: float, length_m: float) -> tuple[float, float, float]:
    """Our centre pose -> SUMO's front-bumper position and navigational angle in degrees."""
    half = 0.5 * length_m
    return x_m + half * math.cos(phi_rad), y_m + half * math.sin(phi_rad), 90.0 - math.degrees(phi_rad)


def front_to_centre(
    x_front_m: float, y_front_m: float, angle_deg: float, length_m: float
) -> tuple[float, float, float]:
    """SUMO's front-bumper position and navigational angle -> our centre pose (phi wrapped to [-pi, pi))."""
    phi = math.radians(90.0 - angle_deg)
    phi = (phi + math.pi) % (2.0 * math.pi) - math.pi
    half = 0.5 * length_m
    return x_front_m - half * math.cos(phi), y_front_m - half * math.sin(phi), phi


def check_net_file(path: Path) -> None:
    """Raise SumoError unless ``path`` is a well-formed XML file whose root is <net>.

    libsumo does not report a malformed net: it crashes the process (measured with SUMO 1.28).
    """
    if not path.is_file():
        raise SumoError(f"network file not found: {path}")

    class Root(xml.sax.ContentHandler):
        seen = False

        def startElement(self, name: str, attrs: object) -> None:  # noqa: N802 (SAX API)
            if not self.seen and name != "net":
                raise SumoError(f"{path} is not a SUMO network: its root element is <{name}>, not <net>")
            self.seen = True

    try:
        xml.sax.parse(str(path), Root())
    except xml.sax.SAXParseException as error:
        raise SumoError(f"malformed network file {path}: {error}") from error
