"""Shared fixtures of the SUMO tests: they run real SUMO (libsumo), one simulation at a time."""

from __future__ import annotations

import pytest

from agentic_mpc.sumo import bridge


@pytest.fixture(autouse=True)
def _no_simulation_left_open():
    """libsumo runs one simulation per process: a test that leaves one open would break the next ones."""
    yield
    leftover = bridge._active
    if leftover is not None:
        leftover.close()
        pytest.fail("a test left a SUMO simulation open")


@pytest.fixture
def report(capsys):
    """Print measured numbers into the test output even without ``-s``."""

    def emit(*lines: str) -> None:
        with capsys.disabled():
            for line in lines:
                print(f"\n    {line}", end="")
            print()

    return emit
