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

from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator, model_validator

from agentic_mpc.controller.config import MPPIConfig
from agentic_mpc.scenario.yaml_source import ScenarioFileError, YamlDocument, YamlPath, deep_merge, load_yaml
from agentic_mpc.sumo.config import LaneRef, SumoConfig
from agentic_mpc.world.plain_config import PlainConfig


class _Strict(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class PathTrackingSettings(_Strict):
    """J1 of the initial specification; the path is the given lane of the ego's road."""

    lane: LaneRef = "center"
    v_ref_mps: float = Field(..., ge=0, le=60)
    weight: float | None = Field(None, gt=0)
    lateral_weight: float | None = Field(None, gt=0, description="cross-track emphasis (1: the paper's)")
    normalise_by_horizon: bool | None = None
    reference_accel_mps2: float | None = Field(None, gt=0)
    paper_reference: bool = Field(False, description="the paper's constant-speed reference points")


class ObstacleAvoidanceSettings(_Strict):
    """J2 of the initial specification over the simulation's obstacles marked ``in_j2`` (discs covering each
    stopped car, inflated by the ego's half size and a margin: ``sumo.surroundings.obstacle_circles``)."""

    penalty: float = Field(100.0, gt=0)


class SpecificationSettings(_Strict):
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


class AgentSettings(_Strict):
    """Which agent runs, how its latency is modelled, and whether what SUMO sees can wake it."""

    backend: Literal["rules", "openai", "llamacpp"] = "rules"
    base_url: str = Field("http://localhost:11434/v1", description="openai backend: the chat-completions endpoint")
    model: str = Field("granite4:micro", description="openai backend: the model name; llamacpp: the GGUF file's path")
    api_key_env: str | None = Field(None, description="openai backend: environment variable holding the API key")
    timeout_s: float = Field(60.0, gt=0, description="openai, llamacpp: seconds per answer; the agent step's "
                             "own timeout is this plus 5 s, so the backend's runs out first")
    tool_mode: Literal["native", "json_schema"] | None = Field(
        None, description="openai, llamacpp: native tool calls, or output constrained by a JSON schema of the "
                          "tools (default: native for openai, json_schema for llamacpp)")
    temperature: float = Field(0.0, ge=0, le=2, description="openai, llamacpp: sampling temperature")
    max_tokens: int = Field(512, ge=1, le=32768, description="openai, llamacpp: tokens per answer")
    extra_body: dict[str, Any] = Field(default_factory=dict,
                                       description="openai: merged into every request body (e.g. top_p)")
    extra_prompt: str = Field("", max_length=8000, description="appended to the system prompt (any backend "
                              "but rules)")
    threads: int = Field(1, ge=1, le=256, description="llamacpp: CPU threads")
    ctx_size: int = Field(8192, ge=256, le=1_048_576, description="llamacpp: context size in tokens")
    max_rounds_per_step: int = Field(6, ge=1, le=100, description="backend answers per agent step (a model "
                                     "that keeps calling tools is stopped there)")
    restore_reminder: bool = Field(False, description="language models: a step whose answer calls no tool while the "
                                   "specification differs from the initial one gets one reminder round saying how "
                                   "it differs (agent/config.py; measured not to help Qwen 1.5B, README)")

    @field_validator("model")
    @classmethod
    def _model_file_for_llamacpp(cls, model: str, info: ValidationInfo) -> str:
        """llamacpp: the GGUF file must exist before anything starts (said with the YAML path / --agent key)."""
        if info.data.get("backend") == "llamacpp":
            from agentic_mpc.agent.backends.llamacpp import check_gguf  # light: no llama.cpp import

            check_gguf(model)
        return model
    mode: Literal["lockstep", "realtime"] = Field(
        "lockstep", description="lockstep: reproducible, tool calls take effect latency_s after the message"
    )
    latency_s: float = Field(0.5, ge=0, description="lockstep: simulated thinking time of the agent")
    observation_messages: bool = Field(False, description="wake the agent when an emergency vehicle approaches")
    alert_distance_m: float = Field(80.0, gt=0, description="how far behind an emergency vehicle starts to matter")


class Message(_Strict):
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


class OutputSettings(_Strict):
    traffic_stride: int = Field(5, ge=1, description="write SUMO vehicles every this many steps")
    plot: bool = True
    replay: bool = Field(True, description="write replay.html, the animated replay of the run")
    plan_stride: int = Field(
        25, ge=1, description="with replay: record the MPPI plan (plan.csv) every this many steps (a rollout costs ms)"
    )


class Scenario(_Strict):
    """One runnable scenario (a variant already applied)."""

    name: str = Field(..., min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    simulation: SumoConfig | None = Field(None, description="the SUMO world (network, traffic, ego, obstacles)")
    plain_world: PlainConfig | None = Field(None, description="or a plain-Python world without SUMO")
    controller: MPPIConfig = MPPIConfig()
    specification: SpecificationSettings
    agent: AgentSettings = AgentSettings()
    messages: tuple[Message, ...] = ()
    duration_s: float = Field(..., gt=0, le=3600)
    stop_at_goal: bool = Field(True, description="end the run when the ego reaches the simulation's goal")
    seed: int = Field(0, ge=0)
    outputs: OutputSettings = OutputSettings()
    variant: str = Field("base", description="set by the loader")

    @model_validator(mode="after")
    def _one_world(self) -> Scenario:
        if (self.simulation is None) == (self.plain_world is None):
            raise ValueError("give exactly one world: simulation (SUMO) or plain_world")
        return self

    @model_validator(mode="after")
    def _messages_inside_the_run(self) -> Scenario:
        for i, message in enumerate(self.messages):
            if message.at_s is not None and message.at_s > self.duration_s:
                raise ValueError(
                    f"messages[{i}].at_s = {message.at_s} s is past the end of the run (duration_s = {self.duration_s})"
                )
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
        if ("simulation" in data) == ("plain_world" in data):
            problems.append(f"{document.locate(prefix)}: give exactly one world: simulation (SUMO) or plain_world")
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
    """Paths in ``simulation`` are relative to the scenario file; missing files are reported here."""
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
        file = (base_dir / value).resolve()
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
