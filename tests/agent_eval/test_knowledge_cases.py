"""The suite's knowledge cases with the rules backend: questions answered from the knowledge server citing
the document, yields by the jurisdiction's rules, a request above the limit capped."""

from agentic_mpc.agent.settings import RulesSettings
from agentic_mpc.agent_eval.runner import run_suite, suite_agent_config
from agentic_mpc.agent_eval.suite import load_suite
from agentic_mpc.agent.backends.rules import RulesBackend


def test_the_rules_get_24_of_the_26_knowledge_cases():
    suite = load_suite()
    cases = suite.select(categories=["knowledge"])
    results = run_suite(suite, cases, lambda lefthand: RulesBackend("left" if lefthand else "right"),
                        suite_agent_config(RulesSettings()))
    right = {r.case.id for r in results if r.right}
    assert len(cases) == 26 and len(right) == 24
    assert {"kb-yield-japan", "kb-yield-germany", "kb-yield-california", "kb-car-length"} <= right
    assert {case.id for case in cases if case.id.startswith("kb-limit-")} <= right  # speeds capped by the rule
    missed = {r.case.id for r in results if not r.right}
    assert missed == {"kb-jp-overtaking-side", "kb-de-hard-shoulder"}  # not read as questions (see docs)
