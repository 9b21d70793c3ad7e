"""What a simulation's files say before SUMO starts: vehicle types, emergency vehicles, lane widths.

Standard library only (no libsumo, no sumolib), so checking a scenario file stays cheap. Used by the scenario
loader (problems with their YAML paths, ``agentic-mpc check``) and by the world (rescue lanes on or off).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

from agentic_mpc.sumo.config import SumoConfig

SUMO_DEFAULT_LANE_WIDTH_M = 3.2
"""netconvert's default when a lane has no width attribute."""

_VEHICLE_TAGS = ("vehicle", "flow", "trip")


class RouteFileError(ValueError):
    """A route file that cannot be read."""


@dataclass
class RouteTypes:
    """The vTypes (id -> vClass), type distributions (id -> member types) and the types vehicles use."""

    vclass: dict[str, str] = field(default_factory=dict)
    distributions: dict[str, tuple[str, ...]] = field(default_factory=dict)
    used: set[str] = field(default_factory=set)
    lc_strategic: dict[str, float] = field(default_factory=dict)
    """vType id -> its lcStrategic attribute, where a route file sets one (SUMO's default is 1)."""

    def known(self, type_id: str) -> bool:
        return type_id in self.vclass or type_id in self.distributions

    def members(self, type_id: str) -> tuple[str, ...]:
        """The vTypes a type id stands for (a distribution's members, or itself)."""
        return self.distributions.get(type_id, (type_id,))

    def emergency_types(self) -> tuple[str, ...]:
        return tuple(t for t, vclass in self.vclass.items() if vclass == "emergency")

    def is_emergency(self, type_id: str) -> bool:
        return any(self.vclass.get(t) == "emergency" for t in self.members(type_id))


def read_route_types(route_files: Iterable[Path]) -> RouteTypes:
    types = RouteTypes()
    for route_file in route_files:
        try:
            root = ElementTree.parse(route_file).getroot()
        except (OSError, ElementTree.ParseError) as error:
            raise RouteFileError(f"cannot read route file {route_file}: {error}") from error
        for element in root.iter():
            if element.tag == "vType" and element.get("id"):
                types.vclass[element.get("id")] = element.get("vClass", "passenger")
                if element.get("lcStrategic") is not None:
                    try:
                        types.lc_strategic[element.get("id")] = float(element.get("lcStrategic"))
                    except ValueError:
                        raise RouteFileError(
                            f"route file {route_file}: vType {element.get('id')!r} has lcStrategic"
                            f" {element.get('lcStrategic')!r}, not a number"
                        ) from None
            elif element.tag == "vTypeDistribution" and element.get("id"):
                nested = tuple(t.get("id") for t in element.iter("vType") if t.get("id"))
                listed = tuple((element.get("vTypes") or "").split())
                types.distributions[element.get("id")] = listed + nested
            elif element.tag in _VEHICLE_TAGS:
                types.used.add(element.get("type", "DEFAULT_VEHTYPE"))
    return types


def type_attribute(route_files: Iterable[Path], type_id: str, name: str, default: float) -> float:
    """A numeric attribute of a vType from the route files (``default`` where the vType does not set it)."""
    route_files = tuple(route_files)
    for route_file in route_files:
        try:
            root = ElementTree.parse(route_file).getroot()
        except (OSError, ElementTree.ParseError) as error:
            raise RouteFileError(f"malformed route file {route_file}: {error}") from error
        for element in root.iter("vType"):
            if element.get("id") == type_id:
                return float(element.get(name, default))
    raise RouteFileError(f"vType {type_id!r} is not defined in the route files {[str(r) for r in route_files]}")


def has_emergency_vehicles(config: SumoConfig, types: RouteTypes | None = None) -> bool:
    """Whether any vehicle of the simulation (route files or the scenario's spawns) is of an emergency class."""
    types = types or read_route_types(config.route_files)
    used = types.used | {v.type_id for v in config.vehicles}
    return any(types.is_emergency(t) for t in used)


def rescue_lanes_active(config: SumoConfig, types: RouteTypes | None = None) -> bool:
    """The rescue-lane setting resolved: explicit on/off, or on exactly when there are emergency vehicles."""
    enabled = config.rescue_lanes.enabled
    return has_emergency_vehicles(config, types) if enabled is None else enabled


def lane_widths_m(net_file: Path, edge_ids: Iterable[str] | None = None) -> dict[str, float]:
    """Lane id -> width of the (non-internal) lanes of ``edge_ids`` (all edges if None)."""
    wanted = None if edge_ids is None else set(edge_ids)
    widths: dict[str, float] = {}
    take = False
    for _, element in ElementTree.iterparse(net_file, events=("start",)):
        if element.tag == "edge":
            edge_id = element.get("id", "")
            take = element.get("function") != "internal" and (wanted is None or edge_id in wanted)
        elif element.tag == "lane" and take:
            widths[element.get("id", "")] = float(element.get("width", SUMO_DEFAULT_LANE_WIDTH_M))
    return widths


def check_files(config: SumoConfig) -> list[tuple[tuple[str | int, ...], str]]:
    """Problems the files reveal, each with its path inside ``simulation`` (checked before SUMO starts)."""
    problems: list[tuple[tuple[str | int, ...], str]] = []
    try:
        types = read_route_types(config.route_files)
    except RouteFileError as error:
        return [(("route_files",), str(error))]
    names = [str(r) for r in config.route_files]
    wanted: list[tuple[tuple[str | int, ...], str]] = [(("ego_type_id",), config.ego_type_id)]
    wanted += [(("vehicles", i, "type_id"), v.type_id) for i, v in enumerate(config.vehicles)]
    wanted += [(("obstacles", i, "type_id"), o.type_id) for i, o in enumerate(config.obstacles)]
    for path, type_id in wanted:
        if not types.known(type_id):
            problems.append((path, f"vehicle type {type_id!r} is not defined in the route files {names}"))
    if config.sublane or rescue_lanes_active(config, types):
        try:
            widths = lane_widths_m(config.net_file)
        except (OSError, ElementTree.ParseError) as error:
            return [*problems, (("net_file",), f"cannot read the network: {error}")]
        if widths and config.lateral_resolution_m > min(widths.values()):
            narrowest = min(widths, key=widths.get)
            message = (f"{config.lateral_resolution_m} m is wider than lane {narrowest!r} ({widths[narrowest]} m):"
                       " SUMO's sublanes must fit in a lane")
            problems.append((("lateral_resolution_m",), message))
    return problems
