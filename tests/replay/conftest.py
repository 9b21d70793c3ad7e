"""Short real runs (written once per session) whose replays the tests read."""

from pathlib import Path

import pytest

from tests.run.conftest import SCENARIOS, plain_run, short_run

__all__ = ["SCENARIOS", "plain_run"]  # plain_run: the fixture, shared with tests/run


@pytest.fixture(scope="session")
def emergency_run(tmp_path_factory) -> Path:
    """Scenario 2 in SUMO, 15 s: the passenger's message at 1 s, the ambulance passes, the agent resumes."""
    return short_run(tmp_path_factory, "paper_emergency_response.yaml", "yield", 15.0)
