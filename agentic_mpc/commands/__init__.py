"""Subcommands of the ``agentic-mpc`` CLI, one module each (see ``agentic_mpc/cli.py``)."""

import argparse
from collections.abc import Callable


def int_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``minimum``, with a message that names the bad value."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    return parse


positive_int = int_at_least(1)
non_negative_int = int_at_least(0)


def scenario_file(text: str):  # -> Path
    """An argparse type: a scenario file's path, or a shipped scenario's name (``agentic-mpc scenarios``).
    Which was used is said on stderr (stdout may be an MCP stream); an unknown name lists the known ones."""
    import sys

    from agentic_mpc.shipped import UnknownScenario, resolve

    try:
        resolved = resolve(text)
    except UnknownScenario as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    if resolved.note:
        print(resolved.note, file=sys.stderr)
    return resolved.path


def backend_name(text: str) -> str:
    """An argparse type: a registered backend's name (agent/settings.py, imported only when parsing)."""
    from agentic_mpc.agent.settings import BACKEND_SETTINGS

    if text not in BACKEND_SETTINGS:
        raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from {', '.join(BACKEND_SETTINGS)})")
    return text


def add_backend_flags(parser: argparse.ArgumentParser) -> None:
    """``--backend`` (the registered backends of agent/settings.py) and its settings as flags, for ``ask`` and
    ``eval-agent``; :func:`flag_settings` reads them back. Defaults are the settings' own (given in brackets)."""
    from pathlib import Path

    parser.add_argument("--backend", type=backend_name, default="rules",
                        help="rules: offline rule-based stand-in (default); openai: an OpenAI-compatible endpoint; "
                             "llamacpp: a GGUF model in this process (or any registered backend)")
    parser.add_argument("--base-url", default=None, help="openai: the endpoint's /v1 URL (default Ollama's)")
    parser.add_argument("--model", default=None, help="openai: model name (granite4:micro)")
    parser.add_argument("--api-key-env", default=None,
                        help="openai: environment variable with the API key (OPENAI_API_KEY; '' for none)")
    parser.add_argument("--timeout-s", type=float, default=None, help="openai, llamacpp: seconds per answer (120)")
    parser.add_argument("--model-path", type=Path, default=None, help="llamacpp: the GGUF model file")
    parser.add_argument("--threads", type=positive_int, default=None, help="llamacpp: CPU threads (1)")
    parser.add_argument("--ctx-size", type=positive_int, default=None, help="llamacpp: context size in tokens (8192)")
    parser.add_argument("--tool-mode", choices=("native", "json_schema"), default=None,
                        help="openai, llamacpp: native tool calling, or the answer constrained by a JSON schema of "
                             "the tools (native for openai, json_schema for llamacpp)")
    parser.add_argument("--confirmation", choices=("template", "model"), default=None,
                        help="openai, llamacpp: after calls that did what the message asked, the reply written from "
                             "their results (template, the default) or by the model")
    parser.add_argument("--temperature", type=float, default=None, help="openai, llamacpp: sampling temperature (0)")
    parser.add_argument("--max-tokens", type=positive_int, default=None, help="openai, llamacpp: tokens per answer "
                                                                              "(512)")
    parser.add_argument("--extra-prompt", default=None, help="openai, llamacpp: appended to the system prompt")
    parser.add_argument("--extra-body", default=None, metavar="JSON",
                        help='openai: merged into every request body, e.g. \'{"top_p": 0.9}\'')
    parser.add_argument("--step-budget-s", type=float, default=None,
                        help="wall seconds an agent step may take (60); 0: no limit")
    parser.add_argument("--step-budget-tokens", type=positive_int, default=None,
                        help="model tokens (processed + generated) an agent step may spend (4096)")
    parser.add_argument("--no-warm-up", dest="warm_up", action="store_false", default=None,
                        help="openai, llamacpp: do not have the model read the system message at the start")
    parser.add_argument("--rules-first", action=argparse.BooleanOptionalAction, default=None,
                        help="openai, llamacpp: the rules backend answers what it understands, the model the rest "
                             "(llamacpp's default; --no-rules-first: the model alone)")
    parser.add_argument("--yield-lane", choices=("left", "right"), default=None,
                        help="rules: where to pull over for emergency vehicles (the road edge's side)")


def agent_setting(text: str) -> tuple[str, str]:
    """An argparse type for ``--agent KEY=VALUE`` (a scenario's ``agent:`` setting; VALUE is read as YAML)."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE (e.g. backend=llamacpp), got {text!r}")
    return key.strip(), value


class CommandInputError(ValueError):
    """A command's input that cannot be used; its message is what to print (exit status 2)."""


def scenario_for(command: str, file, variant: str | None, seed: int | None, pairs: list[tuple[str, str]]):
    """The scenario a command runs: ``file``'s ``variant``, ``seed`` (None: the file's) and ``--agent`` pairs;
    :class:`CommandInputError` with the file's problems or the bad setting, as the command prints it."""
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.scenario.yaml_source import ScenarioFileError

    try:
        scenario = load_scenario(file).variant(variant)
    except ScenarioFileError as error:
        raise CommandInputError(str(error)) from None
    if seed is not None:
        scenario = scenario.with_seed(seed)
    try:
        return with_agent_settings(scenario, pairs)
    except ValueError as error:
        raise CommandInputError(f"agentic-mpc {command}: {error}") from None


def with_agent_settings(scenario, pairs: list[tuple[str, str]]):  # (Scenario, ...) -> Scenario
    """``scenario`` with its ``agent:`` settings overridden by ``--agent KEY=VALUE`` pairs, validated as the
    scenario file's would be (agent/settings.py); ``ValueError`` names the bad key. A new ``backend`` keeps
    the shared settings and drops the old backend's own options."""
    if not pairs:
        return scenario
    import yaml

    from agentic_mpc.agent.settings import with_backend

    given = dict(pairs)
    settings = with_backend(scenario.agent, given["backend"]) if "backend" in given else scenario.agent.model_dump()
    for key, value in pairs:
        if key == "backend":
            continue
        try:
            parsed = yaml.safe_load(value) if value.strip() else ""
        except yaml.YAMLError as error:
            raise ValueError(f"--agent {key}: the value is not YAML ({error})") from None
        if key in TEXT_SETTINGS:
            parsed = value  # a model name such as 1.5 or a path stays text
        if "." in key:  # a nested setting: --agent memory.profile=alice
            section, _, name = key.partition(".")
            settings[section] = {**(settings.get(section) or {}), name: parsed}
        else:
            settings[key] = parsed
    return scenario.model_copy(update={"agent": validated_agent_settings(settings, "--agent ")})


TEXT_SETTINGS = ("model", "base_url", "api_key_env", "extra_prompt", "memory.profile", "memory.file")
"""Agent settings whose values are text even where they read as YAML numbers."""


def validated_agent_settings(settings: dict, flag_prefix: str = "--"):  # -> AgentSettings
    """``settings`` validated as a scenario's ``agent:``; ``ValueError`` naming the first bad one as a flag."""
    from pydantic import ValidationError

    from agentic_mpc.agent.settings import BACKEND_SETTINGS, agent_settings

    try:
        return agent_settings(settings)
    except ValidationError as error:
        first = error.errors()[0]
        location = [str(part) for part in first["loc"]]
        if len(location) > 1 and location[0] in BACKEND_SETTINGS:
            location = location[1:]  # the backend's name is not a setting
        where = ".".join(location)
        if flag_prefix == "--":  # a command-line flag: its own spelling
            llamacpp_model = where == "model" and settings.get("backend") == "llamacpp"
            where = "model-path" if llamacpp_model else where.replace("_", "-")
        if first["type"] == "extra_forbidden":
            raise ValueError(f"{flag_prefix}{where}: not an agent setting of the {settings.get('backend', 'rules')} "
                             f"backend") from None
        raise ValueError(f"{flag_prefix}{where}: {first['msg'].removeprefix('Value error, ')}") from None


def flag_settings(args: argparse.Namespace) -> dict:
    """``ask``'s and ``eval-agent``'s backend flags as agent settings (the ones given; --model-path is the
    llamacpp backend's ``model``); ``ValueError`` for an ``--extra-body`` that is not JSON."""
    import json

    settings: dict = {"backend": args.backend}
    names = ("base_url", "model", "api_key_env", "timeout_s", "threads", "ctx_size", "tool_mode", "temperature",
             "max_tokens", "confirmation", "extra_prompt", "yield_lane", "step_budget_tokens", "warm_up", "rules_first")
    settings.update({name: getattr(args, name) for name in names if getattr(args, name, None) not in (None, "")})
    if getattr(args, "model_path", None) is not None:
        settings["model"] = args.model_path
    if getattr(args, "step_budget_s", None) is not None:
        settings["step_budget_s"] = args.step_budget_s or None  # 0: no limit
    if getattr(args, "api_key_env", None) == "":
        settings["api_key_env"] = None
    if getattr(args, "extra_body", None):
        try:
            settings["extra_body"] = json.loads(args.extra_body)
        except json.JSONDecodeError as error:
            raise ValueError(f"--extra-body is not JSON: {error}") from None
    return settings
