"""Pure helpers of the bridge (no libsumo): SUMO's command line, the net's handedness, error texts."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from xml.etree import ElementTree

SUMO_SEED_MODULUS = 2**31 - 1
"""SUMO's --seed is a C int: a run's seed is taken modulo this (the same for every seed below it)."""


def sumo_command(
    net_file: Path,
    route_files: Sequence[Path],
    *,
    seed: int,
    step_length_s: float,
    lateral_resolution_m: float | None = None,
    bluelight_reaction_dist_m: float | None = None,
    log_file: str | Path | None = None,
    quiet: bool = True,
    extra_options: Sequence[str] = (),
) -> tuple[str, ...]:
    command = [
        "sumo",
        "-n", str(net_file),
        "--step-length", repr(float(step_length_s)),
        "--seed", str(int(seed) % SUMO_SEED_MODULUS),  # SUMO reads an int; LaMPilot's seeds are larger
        "--no-step-log", "true",
        "--duration-log.disable", "true",
        # A standing ego would be teleported away after 300 s by default.
        "--time-to-teleport", "-1",
        # The default (teleport) silently drops collisions of a moveToXY vehicle; warn + real overlap.
        "--collision.action", "warn",
        "--collision.mingap-factor", "0",
        "--collision.check-junctions", "true",
        # Try every pending vehicle each step; by default one that cannot go in blocks the later ones of
        # its edge, so a scenario's vehicles trickled in over seconds (measured).
        "--eager-insert", "true",
    ]
    if route_files:
        command += ["-r", ",".join(str(r) for r in route_files)]
    if lateral_resolution_m is not None:
        command += ["--lateral-resolution", repr(float(lateral_resolution_m))]
    if bluelight_reaction_dist_m is not None:
        # SUMO's 25 m is too short for drivers to clear a lane for an ambulance at 25 m/s (measured)
        command += ["--device.bluelight.reactiondist", repr(float(bluelight_reaction_dist_m))]
    if log_file is not None:
        command += ["--log", str(log_file)]
    if quiet:
        command += ["--no-warnings", "true"]
    return (*command, *extra_options)


def declares_lefthand(net_file: Path) -> bool:
    """Whether the net's root element says lefthand="true" (netconvert --lefthand)."""
    for _, element in ElementTree.iterparse(net_file, events=("start",)):
        return element.get("lefthand", "false").lower() == "true"
    return False


def error_message(error: BaseException) -> str:
    """The text of a libsumo exception (SWIG wraps it in args)."""
    if error.args and isinstance(error.args[0], str):
        return error.args[0].strip()
    return repr(error)
