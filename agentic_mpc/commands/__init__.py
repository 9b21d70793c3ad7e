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


def agent_setting(text: str) -> tuple[str, str]:
    """An argparse type for ``--agent KEY=VALUE`` (a scenario's ``agent:`` setting; VALUE is read as YAML)."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE (e.g. backend=llamacpp), got {text!r}")
    return key.strip(), value


def with_agent_settings(scenario, pairs: list[tuple[str, str]]):  # (Scenario, ...) -> Scenario
    """``scenario`` with its ``agent:`` settings overridden by ``--agent KEY=VALUE`` pairs, validated as the
    scenario file's would be; ``ValueError`` names the bad key."""
    if not pairs:
        return scenario
    import yaml
    from pydantic import ValidationError

    from agentic_mpc.scenario.schema import AgentSettings

    settings = scenario.agent.model_dump()
    for key, value in pairs:
        if key not in AgentSettings.model_fields:
            raise ValueError(f"--agent {key}: not an agent setting (choose from {', '.join(AgentSettings.model_fields)})")
        if AgentSettings.model_fields[key].annotation in (str, str | None, "str", "str | None"):
            settings[key] = value  # a model name such as 1.5 or a path stays text
            continue
        try:
            settings[key] = yaml.safe_load(value) if value.strip() else ""
        except yaml.YAMLError as error:
            raise ValueError(f"--agent {key}: the value is not YAML ({error})") from None
    try:
        agent = AgentSettings.model_validate(settings)
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first["loc"])
        raise ValueError(f"--agent {where}: {first['msg']}") from None
    return scenario.model_copy(update={"agent": agent})


def chat_options(args: argparse.Namespace) -> dict:
    """``ask``'s and ``eval-agent``'s chat-backend flags as backend options (the ones given); ``ValueError``
    for an ``--extra-body`` that is not JSON."""
    import json

    options = {name: getattr(args, name) for name in ("tool_mode", "temperature", "max_tokens")
               if getattr(args, name) is not None}
    if args.extra_body:
        try:
            options["extra_body"] = json.loads(args.extra_body)
        except json.JSONDecodeError as error:
            raise ValueError(f"--extra-body is not JSON: {error}") from None
    return options
