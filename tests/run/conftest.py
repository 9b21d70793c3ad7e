"""Short real runs (written once per session) whose files the tests read back."""

from pathlib import Path

import pytest

from agentic_mpc.scenario.runner import run_scenario
from agentic_mpc.scenario.schema import load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def short_run(tmp_path_factory, file: str, variant: str, duration_s: float) -> Path:
    """The run directory of ``file``'s ``variant`` at seed 0, cut to ``duration_s``."""
    scenario = load_scenario(SCENARIOS / file).variant(variant).with_seed(0)
    scenario = scenario.model_copy(update={"duration_s": duration_s})
    out = tmp_path_factory.mktemp(f"{scenario.name}-{variant}")
    run_scenario(scenario, out)
    return out


@pytest.fixture(scope="session")
def plain_run(tmp_path_factory) -> Path:
    """Scenario 1 in the plain world, 4 s: the passenger asks to pass the obstacle on the right."""
    return short_run(tmp_path_factory, "paper_steering_preference_plain.yaml", "message_right", 4.0)
