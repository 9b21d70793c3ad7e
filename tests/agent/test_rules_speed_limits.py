"""Speeds capped by the limit looked up for the road's type where it is (issue 23): the rules search the
jurisdiction's rules, read the limit for a motorway, rural or urban road from the passage and cite it; closed
loop in SUMO on a motorway with no speed signed."""

from __future__ import annotations

import json

import pytest

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.rules import DrivingState, RulesBackend
from agentic_mpc.agent.backends.rules_knowledge import SEARCH_TOOL, limit_search_call, speed_limit_rule
from agentic_mpc.agent.prompt import describe_road
from agentic_mpc.knowledge.store import KnowledgeBase

DESIGN_SPEED_MPS = 31.29
TOOLS = {
    name: ToolSpec(name, "", {"type": "object", "properties": {"v_ref": {"type": "number", "minimum": 0.0,
                                                                          "maximum": DESIGN_SPEED_MPS}}})
    for name in ("run_left_lane", "run_right_lane", "set_reference_speed", SEARCH_TOOL)
}
STATE = DrivingState("left", 20.0, None)


def found(jurisdiction: str, road_type: str) -> str:
    """What the knowledge server answers the rules' search for the limit (its JSON)."""
    _, arguments = limit_search_call(jurisdiction, road_type)
    passages = KnowledgeBase().search(arguments["query"], 3, jurisdiction)
    return json.dumps({"passages": [{"document": p.doc_id, "section": p.section, "text": p.text,
                                     "cite": p.citation()} for p in passages]})


@pytest.mark.parametrize(("jurisdiction", "road_type", "limit_mps"), [
    ("JP", "motorway", 27.8), ("JP", "rural", 16.7), ("JP", "urban", 16.7),
    ("DE", "motorway", 36.1), ("DE", "rural", 27.8), ("DE", "urban", 13.9),  # the Autobahn's advisory speed
    ("UK", "motorway", 31.3), ("UK", "rural", 26.8), ("UK", "urban", 13.4),
    ("US-CA", "motorway", 29.1), ("US-CA", "rural", 24.6), ("US-CA", "urban", 11.2),
])
def test_the_limit_for_each_road_type_is_read_from_the_shipped_rules(jurisdiction, road_type, limit_mps):
    limit, line, cite = speed_limit_rule(found(jurisdiction, road_type), jurisdiction, road_type)
    assert limit == limit_mps
    assert f"({limit_mps:g} m/s)" in line and jurisdiction.lower() in cite


def test_a_speed_first_searches_then_the_limit_caps_it_and_is_cited():
    rules = RulesBackend()
    plan = rules.plan("Drive at 120 km/h, please.", STATE, STATE, TOOLS, jurisdiction="JP", road_type="motorway")
    assert plan.calls == [(SEARCH_TOOL, {"query": "speed limit motorway Japan", "k": 3, "jurisdiction": "JP"})]
    plan = rules.plan("Drive at 120 km/h, please.", STATE, STATE, TOOLS, jurisdiction="JP", road_type="motorway",
                      found=found("JP", "motorway"))
    assert plan.calls == [("set_reference_speed", {"v_ref": 27.8})]
    assert any("jp-traffic-rules" in note and "100 km/h" in note for note in plan.notes)
    # below the limit the speed is as asked; above the road's design speed that caps it
    plan = rules.plan("Let's go 90 km/h.", STATE, STATE, TOOLS, jurisdiction="JP", road_type="motorway",
                      found=found("JP", "motorway"))
    assert plan.calls == [("set_reference_speed", {"v_ref": 25})]
    plan = rules.plan("Drive at 150 km/h.", STATE, STATE, TOOLS, jurisdiction="DE", road_type="motorway",
                      found=found("DE", "motorway"))
    assert plan.calls == [("set_reference_speed", {"v_ref": DESIGN_SPEED_MPS})]


def test_without_a_road_type_or_a_search_tool_nothing_is_looked_up():
    rules = RulesBackend()
    assert rules.plan("Drive at 25 m/s.", STATE, STATE, TOOLS, jurisdiction="JP").calls == [
        ("set_reference_speed", {"v_ref": 25})]
    no_search = {name: spec for name, spec in TOOLS.items() if name != SEARCH_TOOL}
    assert rules.plan("Drive at 25 m/s.", STATE, STATE, no_search, jurisdiction="JP", road_type="motorway").calls == [
        ("set_reference_speed", {"v_ref": 25})]
    # stopping and yielding are not speeds to look up
    assert rules.plan("Stop the car.", STATE, STATE, TOOLS, jurisdiction="JP", road_type="motorway").calls == [
        ("set_reference_speed", {"v_ref": 0})]


def test_a_result_without_a_limit_for_the_road_type_caps_nothing():
    assert speed_limit_rule(json.dumps({"passages": [{"document": "x", "text": "- Keep left."}]}), "JP",
                            "motorway") is None
    assert speed_limit_rule("not json", "JP", "motorway") is None


def test_a_language_model_is_told_to_look_the_limit_up():
    road = {"lanes": [{"name": "left", "index": 0}], "speed_limit_mps": 31.29, "jurisdiction": "JP",
            "road_type": "motorway"}
    text = "\n".join(describe_road(road))
    assert "a motorway with no speed signed" in text
    assert "look up the speed limit for a motorway in JP" in text


def test_a_road_type_needs_a_jurisdiction():
    from pydantic import ValidationError

    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.shipped import scenario_path

    base = load_scenario(scenario_path("speed_limits_by_jurisdiction")).variant("jp")
    with pytest.raises(ValidationError, match="road_type = 'motorway' needs a jurisdiction"):
        type(base).model_validate({**base.model_dump(), "jurisdiction": None})


@pytest.mark.parametrize(("variant", "v_ref", "cited"), [  # (the goldens pin all four variants' runs)
    ("jp", 27.8, "jp-traffic-rules"), ("de", DESIGN_SPEED_MPS, "de-traffic-rules")])
def test_closed_loop_in_sumo_the_ego_keeps_to_the_limit_of_the_place(tmp_path, variant, v_ref, cited):
    import pandas as pd

    from agentic_mpc.scenario.runner import run_scenario
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.shipped import scenario_path

    scenario = load_scenario(scenario_path("speed_limits_by_jurisdiction")).variant(variant)
    scenario = scenario.model_copy(update={"outputs": scenario.outputs.model_copy(update={"plot": False, "replay": False})})
    summary = run_scenario(scenario, tmp_path)
    trajectory = pd.read_csv(tmp_path / "trajectory.csv")
    assert summary["collisions"] == 0
    assert trajectory["v_ref_mps"].iloc[-1] == pytest.approx(v_ref)
    assert abs(trajectory["v_mps"].iloc[-1] - v_ref) < 0.3  # reached and held, not above it
    assert trajectory["v_mps"].max() < v_ref + 0.5
    events = (tmp_path / "events.csv").read_text()
    assert SEARCH_TOOL in events and cited in events and "Following " in events
