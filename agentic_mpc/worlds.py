"""The kinds of world a scenario can run in, each one registration.

A :class:`WorldKind` says everything the rest of the package needs of a world: the scenario file's key
(``simulation`` for SUMO, ``plain_world`` for the plain-Python world), the config model that key's mapping is
validated with, how to start the world (a :class:`~agentic_mpc.world.base.World`) and how to draw its road
from a run's ``scenario.json`` (plots and replays). The scenario schema, the runner and the plots read
:data:`WORLD_KINDS`; a new world is its module, its config and one :func:`register_world` line.

The built-in kinds name their parts as ``"module:attribute"`` strings, imported on first use, so that
checking a scenario file loads no simulator and this module depends on no layer.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any


def _load(reference: Any) -> Any:
    """An object, or the object a ``"module:attribute"`` string names."""
    if not isinstance(reference, str):
        return reference
    module, _, attribute = reference.partition(":")
    return getattr(importlib.import_module(module), attribute)


@dataclass(frozen=True)
class WorldKind:
    """One kind of world (see the module docstring); ``config``, ``start`` and ``road`` are objects or
    ``"module:attribute"`` strings."""

    key: str
    """The scenario file's key for this world."""
    title: str
    """What ``agentic-mpc scenarios`` calls it."""
    config: Any
    """The config model (a pydantic model class) the key's mapping is validated with."""
    start: Any
    """``start(config, seed) -> World``: the world, started."""
    road: Any
    """``road(config_json: dict) -> RoadDrawing``: the road to draw, from ``scenario.json``'s mapping."""

    def config_model(self) -> Any:
        return _load(self.config)

    def start_world(self, config: Any, seed: int) -> Any:
        return _load(self.start)(config, seed=seed)

    def road_drawing(self, config_json: dict[str, Any]) -> Any:
        return _load(self.road)(config_json)


WORLD_KINDS: dict[str, WorldKind] = {}
"""Every registered kind by its scenario key, in registration order."""



def register_world(kind: WorldKind) -> WorldKind:
    """Add ``kind`` (its key must be new); scenario files may use its key from now on."""
    if kind.key in WORLD_KINDS:
        raise ValueError(f"a world kind with the key {kind.key!r} is registered already")
    WORLD_KINDS[kind.key] = kind
    return kind


def unregister_world(key: str) -> None:
    """Remove a kind again (a test's toy world)."""
    WORLD_KINDS.pop(key, None)


register_world(WorldKind("simulation", "SUMO", "agentic_mpc.sumo.config:SumoConfig",
                         "agentic_mpc.sumo.world:SumoWorld", "agentic_mpc.plots.road:sumo_road"))
register_world(WorldKind("plain_world", "plain Python", "agentic_mpc.world.plain_config:PlainConfig",
                         "agentic_mpc.world.plain:PlainWorld", "agentic_mpc.plots.road:plain_road"))
