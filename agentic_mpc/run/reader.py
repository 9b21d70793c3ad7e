"""The one reader of a run directory (what :mod:`~agentic_mpc.run.recorder` and the scenario runner write,
named in :mod:`~agentic_mpc.run.files`): the figures, the replay, ``agentic-mpc plot`` and the batch's records
all read a run through :class:`RunDirectory`.

A CSV file is read as rows (:meth:`RunDirectory.rows`: strings, with the :mod:`csv` module; a cut-off line is
dropped with a note, so a run that crashed mid-write still reads up to where its files end) or as a table
(:meth:`RunDirectory.table`: pandas, for the figures). ``scenario.json`` gives the run's identity, the road
(rebuilt from it by :func:`agentic_mpc.plots.road.run_road`) and the vehicles' sizes: ``traffic.csv`` has none,
they come from the ``vType``\\ s of the run's route files, or :data:`DEFAULT_SIZES` by vehicle class.

Only the standard library at import time (pandas when a table is asked for): the batch's parent reads records here.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any
from xml.etree import ElementTree

from agentic_mpc.run.files import OBSTACLES, REQUIRED, SCENARIO, SUMMARY, TRAJECTORY

if TYPE_CHECKING:
    import pandas as pd

DEFAULT_SIZES: dict[str, tuple[float, float]] = {
    "passenger": (4.5, 1.8), "private": (4.5, 1.8), "taxi": (4.5, 1.8), "emergency": (6.5, 2.2),
    "truck": (12.0, 2.5), "trailer": (16.5, 2.55), "bus": (12.0, 2.5), "coach": (14.0, 2.6),
    "delivery": (6.5, 2.16), "motorcycle": (2.2, 0.9), "moped": (2.1, 0.8), "bicycle": (1.6, 0.65),
    "ego": (4.5, 1.8),
}
"""(length, width) in metres by SUMO vehicle class when the route files do not say (SUMO's own defaults)."""


class RunDirectoryError(ValueError):
    """A directory that is not a run, or a run file that cannot be read."""


def number(text: Any, default: float = math.nan) -> float:
    """A CSV field as a float (``default`` when empty or not a number)."""
    try:
        return float(text) if text not in (None, "") else default
    except ValueError:
        return default


def is_emergency(flag: Any, vclass: Any) -> bool:
    """Whether a road user is an emergency vehicle: flagged so (``traffic.csv``'s ``emergency``) or of that class."""
    return str(flag).lower() == "true" or vclass == "emergency"


def read_rows(path: Path, required: Iterable[str] = (), notes: list[str] | None = None) -> list[dict[str, str]]:
    """The rows of a CSV file as dicts; a cut-off line (a crashed run) is dropped with a note in ``notes``.
    Raises :class:`RunDirectoryError` when the file cannot be read or lacks a ``required`` column."""
    rows: list[dict[str, str]] = []
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.reader(handle)
            header = next(reader, None)
            if header is None:
                return rows
            missing = [c for c in required if c not in header]
            if missing:
                raise RunDirectoryError(f"{path}: not a run file (missing columns {missing})")
            try:
                for values in reader:
                    if len(values) != len(header):
                        if notes is not None:
                            notes.append(f"{path.name}: a cut-off line after {len(rows)} rows was skipped")
                        continue
                    rows.append(dict(zip(header, values)))
            except csv.Error as error:
                if notes is not None:
                    notes.append(f"{path.name}: stopped reading after {len(rows)} rows ({error})")
    except (OSError, UnicodeDecodeError) as error:
        raise RunDirectoryError(f"{path}: cannot be read ({error})") from error
    return rows


def vehicle_sizes(scenario: Mapping[str, Any], notes: list[str]) -> dict[str, tuple[float, float]]:
    """(length, width) per vType id from the run's route files; the plain world's vehicles by ``@id``."""
    sizes: dict[str, tuple[float, float]] = {}
    for route_file in (scenario.get("simulation") or {}).get("route_files", []):
        try:
            for vtype in ElementTree.parse(route_file).getroot().iter("vType"):
                cls = vtype.get("vClass", "passenger")
                length, width = DEFAULT_SIZES.get(cls, DEFAULT_SIZES["passenger"])
                sizes[vtype.get("id", "")] = (float(vtype.get("length", length)), float(vtype.get("width", width)))
        except (OSError, ElementTree.ParseError, ValueError) as error:
            notes.append(f"vehicle sizes from {route_file} unavailable ({error}); class defaults used")
    for vehicle in (scenario.get("plain_world") or {}).get("vehicles", []):
        diameter = 2.0 * float(vehicle.get("radius_m", 2.0))
        sizes["@" + vehicle["id"]] = (diameter, min(diameter, 1.9))
    return sizes


def size_of(sizes: Mapping[str, tuple[float, float]], vehicle_id: str, type_id: str,
            vclass: str) -> tuple[float, float]:
    """(length, width) of a road user: its own (plain world), its vType's, else its class's default."""
    for key in ("@" + vehicle_id, type_id, type_id.split("@")[0]):
        if key in sizes:
            return sizes[key]
    return DEFAULT_SIZES.get(vclass, DEFAULT_SIZES["passenger"])


def ego_size(scenario: Mapping[str, Any], sizes: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
    """(length, width) of the ego: its SUMO vType's, else the default."""
    ego_type = (scenario.get("simulation") or {}).get("ego_type_id", "ego")
    return sizes.get(ego_type) or DEFAULT_SIZES["ego"]


def run_title(scenario: Mapping[str, Any]) -> str:
    """``name / variant / seed`` of a run's scenario."""
    return " / ".join(str(scenario.get(k, "?")) for k in ("name", "variant", "seed"))


@dataclass(frozen=True)
class Obstacle:
    """One static obstacle as recorded: its id and J2's discs (x, y, radius), in the order recorded."""

    id: str
    discs: tuple[tuple[float, float, float], ...]

    def car(self, sizes: Mapping[str, tuple[float, float]]) -> tuple[float, float, float, float, float] | None:
        """A stopped car's (x, y, heading, length, width) where its discs line up (more than one: SUMO's
        obstacles): at the discs' centre, along the line through the two farthest; None for a single disc."""
        if len(self.discs) < 2:
            return None
        (x0, y0, _), (x1, y1, _) = max(((a, b) for a in self.discs for b in self.discs),
                                       key=lambda ab: math.dist(ab[0][:2], ab[1][:2]))
        length, width = sizes.get("obstacle", DEFAULT_SIZES["passenger"])
        x, y = (sum(d[k] for d in self.discs) / len(self.discs) for k in (0, 1))
        return x, y, math.atan2(y1 - y0, x1 - x0), length, width


def group_obstacles(rows: Iterable[Mapping[str, Any]]) -> list[Obstacle]:
    """``obstacles.csv``'s rows (one per disc) as obstacles, in the order they first appear."""
    groups: dict[str, list[tuple[float, float, float]]] = {}
    for r in rows:
        groups.setdefault(str(r.get("id", "")), []).append(
            (number(r.get("x_m")), number(r.get("y_m")), number(r.get("radius_m"))))
    return [Obstacle(key, tuple(discs)) for key, discs in groups.items()]


class RunDirectory:
    """One run directory, each part read when first asked for; ``notes`` says what could not be read."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.notes: list[str] = []

    def file(self, name: str) -> Path:
        return self.path / name

    def rows(self, name: str) -> list[dict[str, str]]:
        """The rows of the CSV file ``name`` (none without the file); raises :class:`RunDirectoryError` if it
        cannot be read or lacks the columns :data:`~agentic_mpc.run.files.REQUIRED` names."""
        path = self.file(name)
        return read_rows(path, REQUIRED.get(name, ()), self.notes) if path.is_file() else []

    def table(self, name: str) -> pd.DataFrame:
        """The CSV file ``name`` as a table (empty without the file, or when it is empty)."""
        import pandas as pd

        path = self.file(name)
        return pd.read_csv(path) if path.is_file() and path.stat().st_size > 0 else pd.DataFrame()

    def summary(self) -> dict[str, str] | None:
        """The one row of ``summary.csv``; None without the file or unless it holds exactly one row."""
        try:
            rows = read_rows(self.file(SUMMARY))
        except RunDirectoryError:
            return None
        return rows[0] if len(rows) == 1 else None

    @cached_property
    def scenario(self) -> dict[str, Any]:
        """``scenario.json`` ({} with a note when it is missing or unreadable)."""
        path = self.file(SCENARIO)
        if not path.is_file():
            self.notes.append("scenario.json missing: no road drawn")
            return {}
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as error:
            self.notes.append(f"scenario.json unreadable ({error}): no road drawn")
            return {}

    @cached_property
    def sizes(self) -> dict[str, tuple[float, float]]:
        """(length, width) per vType id (:func:`vehicle_sizes`)."""
        return vehicle_sizes(self.scenario, self.notes)

    def size_of(self, vehicle_id: str, type_id: str, vclass: str) -> tuple[float, float]:
        return size_of(self.sizes, vehicle_id, type_id, vclass)

    @property
    def ego_size(self) -> tuple[float, float]:
        return ego_size(self.scenario, self.sizes)

    @cached_property
    def obstacles(self) -> list[Obstacle]:
        """The static obstacles of ``obstacles.csv``."""
        return group_obstacles(self.rows(OBSTACLES))

    @property
    def title(self) -> str:
        """``name / variant / seed`` (the directory's name without a scenario)."""
        return run_title(self.scenario) if self.scenario else self.path.name


def read_run(directory: Path) -> RunDirectory:
    """The run in ``directory``; raises :class:`RunDirectoryError` when it is not one (no ``trajectory.csv``)."""
    directory = Path(directory)
    if not directory.is_dir():
        raise RunDirectoryError(f"{directory}: no such directory")
    if not (directory / TRAJECTORY).is_file():
        raise RunDirectoryError(f"{directory} is not a run directory: {directory / TRAJECTORY} is missing")
    return RunDirectory(directory)
