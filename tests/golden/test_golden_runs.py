"""Behaviour pinned across refactoring: every shipped scenario x variant at seeds 0 and 1 (0 alone for the
jurisdiction families, ``cases.ONE_SEED``) gives the same summary, trajectory and events, to the last written
digit (wall-clock columns aside)."""

from __future__ import annotations

import difflib

import pytest

from tests.golden.cases import DATA, FILES, cases, comparable, run_all


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    return run_all(tmp_path_factory.mktemp("golden"))


def test_every_golden_case_ran(runs):
    assert cases(runs) == cases(DATA)
    assert len(cases(DATA)) >= 20  # 10 variants x 2 seeds


@pytest.mark.parametrize("name", FILES)
def test_outputs_are_unchanged(runs, name):
    changed = []
    for case in cases(DATA):
        expected = (DATA / case / name).read_text(encoding="utf-8")
        actual = comparable(runs / case / name)
        if actual != expected:
            diff = difflib.unified_diff(expected.splitlines(), actual.splitlines(), "golden", "now", n=0, lineterm="")
            changed.append(f"{case}/{name}:\n" + "\n".join(list(diff)[:8]))
    assert not changed, "\n\n".join(changed)
