"""The rules backend looks up how to make way where the road names a jurisdiction: the search, then the
call the rule found calls for, cited; closed loop in SUMO for Japan, Germany and California."""

from __future__ import annotations

import json

import pytest

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.rules import DrivingState, RulesBackend
from agentic_mpc.agent.backends.rules_knowledge import SEARCH_TOOL, yield_rule
from agentic_mpc.knowledge.server import build_knowledge_server  # noqa: F401  (the server the runs use)
from agentic_mpc.knowledge.store import KnowledgeBase
from tests.agent.test_rules_backend import TOOLS

AMBULANCE = "An ambulance is coming behind us. We'd better let them pass."
STATE = DrivingState("center", 15.0, None)
WITH_SEARCH = {**TOOLS, SEARCH_TOOL: ToolSpec(SEARCH_TOOL, "", {"type": "object"})}


def found(jurisdiction: str) -> str:
    """What the knowledge server answers the rules' search (its JSON)."""
    passages = KnowledgeBase().search(f"making way for an emergency vehicle {jurisdiction}", 3, jurisdiction)
    return json.dumps({"passages": [{"document": p.doc_id, "text": p.text, "cite": p.citation()} for p in passages]})


def test_a_yield_first_searches_where_the_road_names_a_jurisdiction():
    plan = RulesBackend().plan(AMBULANCE, STATE, STATE, WITH_SEARCH, jurisdiction="DE")
    assert plan.calls == [(SEARCH_TOOL, {"query": "making way for an emergency vehicle Germany", "k": 3,
                                         "jurisdiction": "DE"})]
    # no jurisdiction, or no search tool: the paper's yield at once, as before
    assert RulesBackend().plan(AMBULANCE, STATE, STATE, WITH_SEARCH).calls == [("run_left_lane", {"v_ref": 0})]
    assert RulesBackend().plan(AMBULANCE, STATE, STATE, TOOLS, jurisdiction="DE").calls == [
        ("run_left_lane", {"v_ref": 0})]


@pytest.mark.parametrize(("jurisdiction", "lane", "v_ref"), [
    ("JP", "left", 0), ("US-CA", "right", 0), ("UK", "left", 0),
    ("DE", "right", 4),  # the rescue lane: from the centre lane to the right, at a crawl
])
def test_the_rule_found_decides_where_and_whether_to_stop(jurisdiction, lane, v_ref):
    plan = RulesBackend().plan(AMBULANCE, STATE, STATE, WITH_SEARCH, jurisdiction=jurisdiction,
                               found=found(jurisdiction))
    assert plan.calls == [(f"run_{lane}_lane", {"v_ref": v_ref})]
    assert any(note.startswith("Following ") and "traffic rules" in note for note in plan.notes)


def test_in_germanys_left_lane_the_car_keeps_left():
    left = DrivingState("left", 15.0, None)
    plan = RulesBackend().plan(AMBULANCE, left, left, WITH_SEARCH, jurisdiction="DE", found=found("DE"))
    assert plan.calls == [("run_left_lane", {"v_ref": 4})]


def test_a_result_that_says_nothing_about_emergency_vehicles_gives_no_rule():
    assert yield_rule(json.dumps({"passages": [{"document": "x", "text": "Keep left."}]}), "JP") is None
    assert yield_rule("not json", "JP") is None


@pytest.mark.parametrize(("variant", "lane", "stopped", "cited"), [
    ("jp", "left", True, "jp-traffic-rules"), ("de", "right", False, "de-traffic-rules"),
    ("us", "right", True, "us-ca-traffic-rules")])
def test_closed_loop_in_sumo_the_ego_makes_way_as_the_place_says(tmp_path, variant, lane, stopped, cited):
    import pandas as pd

    from agentic_mpc.scenario.runner import run_scenario
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.shipped import scenario_path

    scenario = load_scenario(scenario_path("emergency_by_jurisdiction")).variant(variant)
    scenario = scenario.model_copy(update={"outputs": scenario.outputs.model_copy(update={"plot": False, "replay": False})})
    summary = run_scenario(scenario, tmp_path)
    trajectory = pd.read_csv(tmp_path / "trajectory.csv")
    yielding = trajectory[trajectory["spec_summary"].str.contains(f"lane={lane}, ")]
    assert len(yielding) > 50 and summary["collisions"] == 0
    assert yielding["lane_role"].iloc[-1] == lane
    assert (yielding["v_mps"].min() < 0.5) == stopped
    events = (tmp_path / "events.csv").read_text()
    assert SEARCH_TOOL in events and cited in events and "Following " in events
    assert summary["ambulance_delay_s"] < 5.0
