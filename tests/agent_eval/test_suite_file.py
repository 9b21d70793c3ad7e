"""The shipped evaluation suite: it loads, is large enough, covers every category, and its expectations
agree with its worlds (yielding pulls over to the edge lane of THAT road); a malformed suite is refused
with the file and the case id named."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from agentic_mpc.agent_eval.suite import DEFAULT_SUITE, SuiteError, load_suite
from agentic_mpc.scenario.schema import load_scenario


@pytest.fixture(scope="module")
def suite():
    return load_suite()


def test_the_shipped_suite_has_at_least_80_cases_in_every_category(suite):
    counts = Counter(case.category for case in suite.cases)
    assert len(suite.cases) >= 80
    assert set(counts) == set(suite.categories), f"categories without cases: {set(suite.categories) - set(counts)}"
    assert min(counts.values()) >= 5, counts
    assert sum(len(case.turns) > 1 for case in suite.cases) >= 10  # multi-turn dialogues
    assert sum(not turn.expect for case in suite.cases for turn in case.turns) >= 12  # turns that need no call
    assert sum(len(turn.expect) == 2 for case in suite.cases for turn in case.turns) >= 8  # compound requests


def test_the_non_english_cases_cover_four_languages(suite):
    messages = [case.turns[0].message for case in suite.cases if case.category == "non_english"]
    assert any("Krankenwagen" in m or "Hindernisse" in m for m in messages)  # German
    assert any("救急車" in m for m in messages)  # Japanese
    assert any("velocidad" in m or "izquierda" in m for m in messages)  # Spanish
    assert any("gauche" in m or "derrière" in m for m in messages)  # French


def test_yielding_expects_the_edge_lane_of_each_cases_road(suite):
    plain = {name: load_scenario(ref.scenario).variant(ref.variant).plain_world for name, ref in suite.worlds.items()}
    lefthand = {name: world.road.lefthand for name, world in plain.items() if world is not None}  # the knowledge
    assert set(lefthand.values()) == {True, False}, "both handednesses must be in the suite"  # worlds are SUMO's
    yields = [case for case in suite.cases if case.category == "yield"]
    assert {case.world for case in yields} == set(lefthand)
    for case in yields:
        edge = "left" if lefthand[case.world] else "right"
        (call,) = case.turns[0].expect
        assert call.tools == (f"run_{edge}_lane",), case.id
        assert call.matches(f"run_{edge}_lane", {"v_ref": 0}, 15.0), case.id
        assert not call.matches(f"run_{edge}_lane", {"v_ref": 15}, 15.0), case.id


def _write(tmp_path: Path, cases: str) -> Path:
    path = tmp_path / "suite.yaml"
    path.write_text(f"""
worlds:
  lefthand: {{scenario: {DEFAULT_SUITE.parents[2] / 'scenarios/paper_steering_preference_plain.yaml'}}}
categories: {{side: sides}}
cases:
{cases}
""", encoding="utf-8")
    return path


@pytest.mark.parametrize("case, complaint", [
    (("  - {id: bad-range, category: side, world: lefthand, message: hi,\n"
     "     expect: [{tool: set_reference_speed, args: {v_ref: {range: [20, 10]}}}]}"), "range must be [LOW, HIGH]"),
    ("  - {id: bad-world, category: side, world: nowhere, message: hi, expect: []}", "world 'nowhere'"),
    ("  - {id: no-expect, category: side, world: lefthand, message: hi}", "has no expect"),
    ("  - {id: bad-category, category: jokes, world: lefthand, message: hi, expect: []}", "category 'jokes'"),
    ("  - {id: bad-key, category: side, world: lefthand, message: hi, expect: [], expected: []}", "unknown key"),
    (("  - {id: bad-constraint, category: side, world: lefthand, message: hi,\n"
     "     expect: [{tool: run_left_lane, args: {v_ref: {about: 3}}}]}"), "unknown constraint 'about'"),
])
def test_a_malformed_case_is_refused_naming_the_file_and_the_case(tmp_path, case, complaint):
    path = _write(tmp_path, "  - {id: fine, category: side, world: lefthand, message: ok, expect: []}\n" + case)
    with pytest.raises(SuiteError) as raised:
        load_suite(path)
    case_id = case.split("id: ")[1].split(",")[0]
    assert len(raised.value.problems) == 1, raised.value.problems
    assert str(path) in str(raised.value) and f"case {case_id!r}" in str(raised.value)
    assert complaint in str(raised.value)


def test_a_file_that_is_not_yaml_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("cases: [ {id: x\n", encoding="utf-8")
    with pytest.raises(SuiteError, match="broken.yaml: not YAML"):
        load_suite(path)


def test_duplicate_ids_and_every_problem_are_reported(tmp_path):
    path = _write(tmp_path, "  - {id: twice, category: side, world: lefthand, message: a, expect: []}\n"
                            "  - {id: twice, category: side, world: lefthand, message: b, expect: []}\n"
                            "  - {id: other, category: nope, world: lefthand, message: c, expect: []}\n")
    with pytest.raises(SuiteError) as raised:
        load_suite(path)
    assert [p.split(": ", 1)[1] for p in raised.value.problems] == [
        "case 'twice': duplicate id", "case 'other': category 'nope' is not declared (declared: side)"]


def test_selecting_by_category_id_and_sample(suite):
    assert {c.category for c in suite.select(["yield"])} == {"yield"}
    sample = suite.select(per_category=2)
    assert len(sample) == 2 * len(suite.categories)
    assert [c.id for c in suite.select(case_ids=["side-left-paper"])] == ["side-left-paper"]
    assert len(suite.select(limit=3)) == 3
    with pytest.raises(SuiteError, match="no category 'jokes'"):
        suite.select(["jokes"])
