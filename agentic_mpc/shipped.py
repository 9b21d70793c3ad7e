"""The scenarios and SUMO networks that come with the package, found by name wherever it is installed.

In a checkout they are the top-level ``scenarios/`` and ``sumo_nets/``; the package reaches them through
``agentic_mpc/shipped-data/`` (two links), and a wheel carries them there as plain files, so the scenarios'
relative paths (``../sumo_nets/curvy.net.xml``) hold in both. ``AGENTIC_MPC_SUMO_NETS`` overrides the nets.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

DATA = Path(__file__).resolve().parent / "shipped-data"
SUFFIX = ".yaml"


def scenarios_dir() -> Path:
    """The folder of the shipped scenario files (resolved: a checkout's top-level ``scenarios/``)."""
    return (DATA / "scenarios").resolve()


def nets_dir() -> Path:
    """The folder with the nets and route files (``AGENTIC_MPC_SUMO_NETS`` overrides it)."""
    override = os.environ.get("AGENTIC_MPC_SUMO_NETS")
    return Path(override) if override else (DATA / "sumo_nets").resolve()


def scenario_names() -> list[str]:
    """The shipped scenarios' names (their file stems), sorted."""
    return sorted(path.stem for path in scenarios_dir().glob(f"*{SUFFIX}"))


def scenario_path(name: str) -> Path:
    """The shipped scenario ``name`` (with or without ``.yaml``); :class:`UnknownScenario` if there is none."""
    stem = name[: -len(SUFFIX)] if name.endswith(SUFFIX) else name
    path = scenarios_dir() / f"{stem}{SUFFIX}"
    if "/" in stem or os.sep in stem or not path.is_file():
        raise UnknownScenario(name)
    return path


class UnknownScenario(ValueError):
    """Neither a file nor a shipped scenario's name; the message lists the names."""

    def __init__(self, name: str) -> None:
        self.name = name
        super().__init__(f"{name}: no such file, and no shipped scenario of that name; the shipped ones are: "
                         + ", ".join(scenario_names()) + " (agentic-mpc scenarios lists them)")


@dataclass(frozen=True)
class Resolved:
    """Which file a scenario argument named, and how it was read."""

    path: Path
    shipped: bool
    """True when the argument was a shipped scenario's name (not a path)."""
    note: str | None
    """What to tell the user: which was used, where the argument could mean two things or named a shipped one."""


def resolve(argument: str | Path) -> Resolved:
    """A scenario argument: a path if such a file exists (the current directory first), else a shipped
    scenario's name. A name that is also a file here is read as the file, and the note says so. Something
    with a directory in it is a path even where no such file exists (the loader then says it cannot read it,
    beside any other file's problems); a bare word that is neither is :class:`UnknownScenario`."""
    text = str(argument)
    given = Path(text).expanduser()
    try:
        shipped = scenario_path(text)
    except UnknownScenario:
        shipped = None
    if given.is_file():
        note = None
        if shipped is not None and given.resolve() != shipped:
            note = f"{text}: read as the file {given.resolve()} (a shipped scenario has that name too)"
        return Resolved(given, False, note)
    if shipped is None:
        if len(given.parts) > 1:
            return Resolved(given, False, None)
        raise UnknownScenario(text)
    return Resolved(shipped, True, f"{text}: the shipped scenario {shipped}")


def copy_scenario(name: str, directory: Path) -> list[Path]:
    """Copy the shipped scenario ``name`` into ``directory`` to edit, with the network and route files it
    names beside it in ``directory/sumo_nets/`` and its ``../sumo_nets/`` paths made ``sumo_nets/``. Refuses
    to overwrite. Returns the files written, the scenario first."""
    import yaml

    source = scenario_path(name)
    directory = Path(directory)
    text = source.read_text(encoding="utf-8")
    referenced = sorted({Path(value).name for value in _strings(yaml.safe_load(text)) if value.startswith("../sumo_nets/")})
    targets = [directory / source.name] + [directory / "sumo_nets" / file for file in referenced]
    existing = [str(path) for path in targets if path.exists()]
    if existing:
        raise FileExistsError(f"not overwriting {', '.join(existing)}")
    (directory / "sumo_nets" if referenced else directory).mkdir(parents=True, exist_ok=True)
    targets[0].write_text(text.replace("../sumo_nets/", "sumo_nets/"), encoding="utf-8")
    for file, target in zip(referenced, targets[1:]):
        shutil.copyfile(nets_dir() / file, target)
    return targets


def _strings(data: object):
    if isinstance(data, str):
        yield data
    elif isinstance(data, dict):
        for value in data.values():
            yield from _strings(value)
    elif isinstance(data, list):
        for value in data:
            yield from _strings(value)
