"""The scenario file, as typed and validated objects.

A scenario is one YAML file (see ``scenarios/`` and the README): the world (``simulation``: SUMO's network,
routes, traffic, ego and obstacles; or ``plain_world``), the controller, the initially attached primitives, the agent, a timeline of user
messages, the duration and seed, and named variants that override any of these. :func:`load_scenario`
validates the base and every variant before anything runs and reports every problem with its file, line
and YAML path.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_serializer, model_validator
from pydantic_core import PydanticCustomError

from agentic_mpc.agent.settings import BACKEND_SETTINGS, AgentSettings, RulesSettings, agent_settings
from agentic_mpc.controller.config import MPPIConfig
from agentic_mpc.frozen_config import FrozenConfig
from agentic_mpc.scenario.yaml_source import ScenarioFileError, YamlDocument, YamlPath, deep_merge, load_yaml
from agentic_mpc.sumo.config import LaneRef, SumoConfig
from agentic_mpc.tactics.config import TacticsConfig
from agentic_mpc.worlds import WORLD_KINDS


class PathTrackingSettings(FrozenConfig):
    """J1 of the initial specification; the path is the given lane of the ego's road."""

    lane: LaneRef = "center"
    v_ref_mps: float = Field(..., ge=0, le=60)
    weight: float | None = Field(None, gt=0)
    lateral_weight: float | None = Field(None, gt=0, description="cross-track emphasis (1: the paper's)")
    normalise_by_horizon: bool | None = None
    reference_accel_mps2: float | None = Field(None, gt=0)
    paper_reference: bool = Field(False, description="the paper's constant-speed reference points")


class ObstacleAvoidanceSettings(FrozenConfig):
    """J2 of the initial specification over the simulation's obstacles marked ``in_j2`` (discs covering each
    stopped car, inflated by the ego's half size and a margin: ``tactics.covers.obstacle_circles``)."""

    penalty: float = Field(100.0, gt=0)


class SpecificationSettings(FrozenConfig):
    """The initially attached primitives (J0 is always attached; its weights may be set here)."""

    mandatory: dict[str, Any] = Field(default_factory=dict)
    path_tracking: PathTrackingSettings | None = None
    obstacle_avoidance: ObstacleAvoidanceSettings | None = None
    preferred_steering_direction: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _validate_with_the_primitives(self) -> SpecificationSettings:
        if self.mandatory or self.preferred_steering_direction is not None:
            # imported only when there is something to check: the primitives load numpy and the kernels
            from agentic_mpc.primitives import Mandatory, PreferredSteeringDirection

            Mandatory.model_validate(self.mandatory)
            if self.preferred_steering_direction is not None:
                PreferredSteeringDirection.model_validate(self.preferred_steering_direction)
        return self


class Message(FrozenConfig):
    """A user message at a simulation time, or a delay after an event."""

    text: str = Field(..., min_length=1, max_length=4000)
    at_s: float | None = Field(None, ge=0)
    event: Literal["emergency_vehicle_approaching", "emergency_vehicle_passed"] | None = Field(
        None,
        description="wait for an emergency vehicle within the agent's alert distance behind the ego, or for it "
        "to have passed (YAML reads a key named `on` as true, hence `event`)",
    )
    delay_s: float = Field(0.0, ge=0, description="with ``event``: seconds after it")

    @model_validator(mode="after")
    def _one_trigger(self) -> Message:
        if (self.at_s is None) == (self.event is None):
            raise ValueError("give exactly one of at_s (a time) or event (an event to wait for)")
        return self


class OutputSettings(FrozenConfig):
    traffic_stride: int = Field(5, ge=1, description="write SUMO vehicles every this many steps")
    plot: bool = True
    replay: bool = Field(True, description="write replay.html, the animated replay of the run")
    plan_stride: int = Field(
        25, ge=1, description="with replay: record the MPPI plan (plan.csv) every this many steps (a rollout costs ms)"
    )


class Scenario(FrozenConfig):
    """One runnable scenario (a variant already applied)."""

    name: str = Field(..., min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    world_kind: str = Field(..., description="the world's key in the file: simulation (SUMO), plain_world, or any "
                                             "kind registered in agentic_mpc/worlds.py")
    world: Any = Field(..., description="that key's mapping, validated by the kind's config model")
    controller: MPPIConfig = MPPIConfig()
    specification: SpecificationSettings
    agent: AgentSettings = Field(default_factory=RulesSettings, description="which agent runs and how "
                                 "(agent/settings.py; a flat mapping, its backend key choosing the options)")
    tactics: TacticsConfig = Field(TacticsConfig(), description="the driving tactics in force and their parameters "
                                   "(agentic_mpc/tactics; worlds that offer a tactical road apply them)")
    messages: tuple[Message, ...] = ()
    duration_s: float = Field(..., gt=0, le=3600)
    stop_at_goal: bool = Field(True, description="end the run when the ego reaches the simulation's goal")
    seed: int = Field(0, ge=0)
    jurisdiction: str | None = Field(
        None, pattern=r"^[A-Z]{2}(-[A-Z0-9]{1,3})?$", description="whose traffic rules apply (JP, DE, UK, US-CA, ...): "
        "sumo://road says it; an agent with the knowledge server looks the rules up (docs/knowledge.md)")
    road_type: Literal["motorway", "rural", "urban"] | None = Field(
        None, description="the road's type where no speed is signed: the jurisdiction's limit for it applies below "
        "the network's lane speed (its design speed), and an agent with the knowledge server looks it up")
    outputs: OutputSettings = OutputSettings()
    variant: str = Field("base", description="set by the loader")

    @model_validator(mode="wrap")
    @classmethod
    def _registered_parts(cls, data: Any, handler: Any) -> Scenario:
        """The parts chosen from a registry, validated by what was registered: the file's one world key
        (agentic_mpc/worlds.py) and the agent by its backend (agent/settings.py). Their errors and the rest
        of the file's are reported together, each at its own YAML path."""
        if not isinstance(data, dict) or "world" in data:
            return handler(data)
        present = [key for key in WORLD_KINDS if data.get(key) is not None]
        rest = {key: value for key, value in data.items() if key not in WORLD_KINDS}
        errors: list[Any] = []
        if len(present) != 1:
            names = " or ".join(f"{kind.key} ({kind.title})" for kind in WORLD_KINDS.values())
            errors.append({"type": "value_error", "loc": (), "input": data,
                           "msg": f"Value error, give exactly one world: {names}"})
        else:
            try:
                rest.update(world_kind=present[0], world=WORLD_KINDS[present[0]].config_model().model_validate(
                    data[present[0]]))
            except ValidationError as error:
                errors += [{**item, "loc": (present[0], *item["loc"])} for item in error.errors()]
        if isinstance(data.get("agent", {}), dict):
            try:
                rest["agent"] = agent_settings(data.get("agent", {}))
            except ValidationError as error:  # a location's first part is the backend's name, not a key
                for item in error.errors():
                    tagged = bool(item["loc"]) and item["loc"][0] in BACKEND_SETTINGS
                    if item["type"] == "extra_forbidden" and tagged:
                        item = {**item, "msg": f"not a setting of the {item['loc'][0]} backend"}
                    errors.append({**item, "loc": ("agent", *item["loc"][1 if tagged else 0:])})
                rest.pop("agent")
        try:
            scenario = handler(rest)
        except ValidationError as error:  # "world missing" is said above, in the file's words
            errors += [item for item in error.errors() if item["loc"][:1] not in (("world",), ("world_kind",))]
        if errors:  # re-raised as one error, each item keeping its location and words
            raise ValidationError.from_exception_data(cls.__name__, [
                {"type": PydanticCustomError(item["type"], item["msg"]), "loc": item["loc"], "input": item.get("input")}
                for item in errors])
        return scenario

    @model_serializer(mode="wrap")
    def _world_under_its_key(self, handler: Any) -> dict[str, Any]:
        """``scenario.json`` keeps the file's shape: the world under its own key."""
        data = handler(self)
        kind, world = data.pop("world_kind"), data.pop("world")
        return {key: data[key] for key in ("name", "description")} | {kind: world} | data

    @property
    def simulation(self) -> Any:
        """The SUMO world's config, or None."""
        return self.world if self.world_kind == "simulation" else None

    @property
    def plain_world(self) -> Any:
        """The plain-Python world's config, or None."""
        return self.world if self.world_kind == "plain_world" else None

    @model_validator(mode="after")
    def _messages_inside_the_run(self) -> Scenario:
        for i, message in enumerate(self.messages):
            if message.at_s is not None and message.at_s > self.duration_s:
                raise ValueError(
                    f"messages[{i}].at_s = {message.at_s} s is past the end of the run (duration_s = {self.duration_s})"
                )
        if self.road_type is not None and self.jurisdiction is None:
            raise ValueError(f"road_type = {self.road_type!r} needs a jurisdiction (whose limit for it applies)")
        return self

    def with_seed(self, seed: int) -> Scenario:
        return self.model_copy(update={"seed": seed})


class ScenarioFile(BaseModel):
    """A validated scenario file: the base scenario and every variant."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    path: Path
    base: Scenario
    variants: dict[str, Scenario]

    def variant(self, name: str | None) -> Scenario:
        if name is None or name == "base":
            return self.base
        if name not in self.variants:
            raise ScenarioFileError(
                self.path, [f"{self.path}: unknown variant {name!r}; variants: {', '.join(self.variants) or '(none)'}"]
            )
        return self.variants[name]

    @property
    def variant_names(self) -> list[str]:
        return list(self.variants) or ["base"]


def load_scenario(path: Path | str) -> ScenarioFile:
    """Read and validate a scenario file and all its variants; raise :class:`ScenarioFileError` listing every problem."""
    document = load_yaml(path)
    raw = document.data
    if not isinstance(raw, dict):
        raise ScenarioFileError(document.file, [f"{document.locate(())}: a scenario is a mapping of keys"])
    problems: list[str] = []
    variants_raw = raw.get("variants", {}) or {}
    if not isinstance(variants_raw, dict):
        problems.append(f"{document.locate(('variants',))}: variants is a mapping of name -> overrides")
        variants_raw = {}
    base_raw = {k: v for k, v in raw.items() if k != "variants"}
    base = _validate(document, base_raw, (), problems)
    variants: dict[str, Scenario] = {}
    for name, override in variants_raw.items():
        if not isinstance(override, dict):
            problems.append(f"{document.locate(('variants', name))}: a variant is a mapping of overrides")
            continue
        merged = deep_merge(base_raw, {**override, "variant": str(name)})
        scenario = _validate(document, merged, ("variants", name), problems)
        if scenario is not None:
            variants[str(name)] = scenario
    if problems or base is None:  # variants inherit the base's problems: report each once
        raise ScenarioFileError(document.file, list(dict.fromkeys(problems)))
    return ScenarioFile(path=document.file, base=base, variants=variants)


def _validate(document: YamlDocument, data: dict[str, Any], prefix: YamlPath, problems: list[str]) -> Scenario | None:
    data = _resolve_files(document, data, prefix, problems)
    try:
        scenario = Scenario.model_validate(data)
        if scenario.simulation is not None:
            problems.extend(_simulation_file_problems(document, scenario.simulation, prefix))
        return scenario
    except ValidationError as error:
        # pydantic skips model checks when a field fails: run the whole-file checks here so every problem shows
        problems.extend(_messages_past_the_end(document, data, prefix))
        for item in error.errors():
            location = tuple(item["loc"])
            # an override's own line if the variant set this value, else the base file's line
            path = (*prefix, *location) if prefix and document.line_of((*prefix, *location)) != document.line_of(prefix) else location
            message = item["msg"].removeprefix("Value error, ")
            problems.append(f"{document.locate(path)}: {message}")
        return None


def _simulation_file_problems(document: YamlDocument, simulation: SumoConfig, prefix: YamlPath) -> list[str]:
    """What the simulation's files contradict (vehicle types, lane widths), checked before SUMO starts."""
    from agentic_mpc.sumo.route_files import check_files  # XML only: no simulator is loaded

    found = []
    for inner, message in check_files(simulation):
        path: YamlPath = ("simulation", *inner)
        where = (*prefix, *path) if prefix and (*prefix, *path) in document.lines else path
        found.append(f"{document.locate(where)}: {message}")
    return found


def _messages_past_the_end(document: YamlDocument, data: dict[str, Any], prefix: YamlPath) -> list[str]:
    duration, messages = data.get("duration_s"), data.get("messages")
    if not isinstance(duration, int | float) or not isinstance(messages, list):
        return []
    found = []
    for i, message in enumerate(messages):
        at = message.get("at_s") if isinstance(message, dict) else None
        if isinstance(at, int | float) and at > duration:
            path: YamlPath = ("messages", i, "at_s")
            where = (*prefix, *path) if prefix and (*prefix, *path) in document.lines else path
            found.append(f"{document.locate(where)}: {at} s is past the end of the run (duration_s = {duration})")
    return found


def _resolve_files(document: YamlDocument, data: dict[str, Any], prefix: YamlPath, problems: list[str]) -> dict[str, Any]:
    """Paths in ``simulation`` are relative to the scenario file (``sumo:`` ones inside SUMO's installed package);
    missing files are reported here."""
    from agentic_mpc.sumo.config import SUMO_PREFIX, installed_sumo_file  # pydantic only
    simulation = data.get("simulation")
    if not isinstance(simulation, dict):
        return data
    base_dir = document.file.parent
    simulation = dict(simulation)
    routes = simulation.get("route_files", [])
    keys: list[tuple[YamlPath, Any]] = [(("simulation", "net_file"), simulation.get("net_file"))]
    keys += [(("simulation", "route_files", i), r) for i, r in enumerate(routes if isinstance(routes, list) else [routes])]
    resolved: dict[YamlPath, Path] = {}
    for path, value in keys:
        if not isinstance(value, str):
            continue
        file = installed_sumo_file(value) if value.startswith(SUMO_PREFIX) else (base_dir / value).resolve()
        if not file.is_file():
            where = (*prefix, *path) if prefix and (*prefix, *path) in document.lines else path
            problems.append(f"{document.locate(where)}: file not found: {file}")
        resolved[path] = file
    if ("simulation", "net_file") in resolved:
        simulation["net_file"] = resolved[("simulation", "net_file")]
    if isinstance(routes, list):
        simulation["route_files"] = [resolved.get(("simulation", "route_files", i), r) for i, r in enumerate(routes)]
    elif ("simulation", "route_files", 0) in resolved:
        simulation["route_files"] = [resolved[("simulation", "route_files", 0)]]
    return {**data, "simulation": simulation}
