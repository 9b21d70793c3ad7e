"""Memory across runs (agent/memory.py, memory_recall.py, memory_rules.py): real files, a real MCP server in
process, two runs of one passenger profile; the file's bad input; the measurement on the dialogue set."""

from __future__ import annotations

import asyncio
import json
import logging

import pytest
import yaml
from mcp import Client

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.memory import MemoryFileError, MemorySettings, MemoryStore, read_memory_file, tfidf_similarities
from agentic_mpc.agent.settings import OpenAISettings
from agentic_mpc.mcp.protocol import MEMORY_URI
from agentic_mpc.run.loop import AgentSetup
from tests.agent.conftest import paper_start_config, plain_loop
from tests.agent.scripted_llm import ScriptedLLM, text


def _memory(path, **options) -> MemorySettings:
    return MemorySettings(profile="alice", file=path, **options)


def _run(messages, memory: MemorySettings | None, backend=None):
    """One run: a plain world, its MCP server, a realtime rules agent with ``memory``; the reports, what
    ``agent://memory`` showed at the end, and the transcript."""
    config = AgentConfig(mode="realtime", knowledge=False, memory=memory)
    with plain_loop(paper_start_config(), agent=AgentSetup(backend or RulesBackend(), config)) as loop:
        reports = [loop.agent.deliver(m).result(30) for m in messages]

        async def read():
            async with Client(loop.server.mcp_server) as client:
                return json.loads((await client.read_resource(MEMORY_URI)).contents[0].text)

        shown = asyncio.run(read())
        return reports, shown, loop.transcript


def _replies(transcript) -> str:
    """Everything the agent answered in a run (its notes are in the answer that made the calls)."""
    return " ".join(r["content"] for r in transcript if r.get("role") == "assistant")


def _calls(report):
    return [(str(c["tool"]), c["arguments"]) for c in report.applied_calls]


def test_a_preference_and_a_correction_of_run_1_answer_run_2_and_are_shown_in_the_resource(tmp_path):
    path = tmp_path / "alice.yaml"
    reports, shown, transcript = _run(["I always prefer passing obstacles on the left.",
                                       "Keep the obstacles on the left.", "No, the other side."], _memory(path))
    assert _calls(reports[1]) == [("set_preferred_steering_direction", {"direction": "right"})]  # the rules' reading
    assert _calls(reports[2]) == [("set_preferred_steering_direction", {"direction": "left"})]  # corrected in the run
    written = yaml.safe_load(path.read_text())
    assert written["version"] == 1 and written["profile"] == "alice"
    assert [(e["id"], e["kind"]) for e in written["entries"]] == [(1, "preference"), (2, "correction")]
    assert written["entries"][0]["means"] == {"preferred_side": "left"}
    assert written["entries"][1]["corrects"] == "Keep the obstacles on the left."
    assert written["entries"][1]["wrong"] == [{"tool": "set_preferred_steering_direction",
                                               "arguments": {"direction": "right"}}]
    assert shown["profile"] == "alice" and shown["preferences"] == {"preferred_side": {"value": "left", "entry": 1}}
    assert len(shown["entries"]) == 2
    assert [r["entry"]["id"] for r in transcript if r.get("event") == "memory_learned"] == [1, 2]

    later = ["There is a parked van ahead, go around it.", "Keep the obstacles on the left."]
    with_memory, _, transcript = _run(later, _memory(path))
    without, shown_without, _ = _run(later, None)
    assert [_calls(r) for r in with_memory] == [[("set_preferred_steering_direction", {"direction": "left"})]] * 2
    assert [_calls(r) for r in without] == [[], [("set_preferred_steering_direction", {"direction": "right"})]]
    assert "Evading on the left, as you prefer." in _replies(transcript)
    assert "As you corrected me before (\"Keep the obstacles on the left.\", memory entry 2)" in _replies(transcript)
    recalled = [r for r in transcript if r.get("event") == "memory_recalled"]
    assert recalled[1]["similar"][0][0] == 2 and recalled[1]["similar"][0][1] == 1.0  # the correction, same words
    assert shown_without == {"profile": None, "entries": []}
    assert len(yaml.safe_load(path.read_text())["entries"]) == 2  # run 2 stated nothing new


def test_a_yield_side_and_a_speed_cap_apply_only_where_the_message_leaves_them_open(tmp_path):
    path = tmp_path / "alice.yaml"
    _run(["Whenever an ambulance comes, pull over to the right.", "I never want to go faster than 60 km/h."],
         _memory(path))
    assert read_memory_file(path)[0].means.yield_side == "right"
    assert read_memory_file(path)[1].means.max_speed_mps == pytest.approx(16.667)
    reports, _, transcript = _run(["An ambulance is coming behind us.", "The ambulance has passed.", "Go a little faster.",
                          "Drive at 20 m/s.", "Pull over to the left for the fire engine."], _memory(path))
    assert [_calls(r) for r in reports] == [
        [("run_right_lane", {"v_ref": 0})],  # the side they prefer
        [("run_center_lane", {"v_ref": 15})],
        [("set_reference_speed", {"v_ref": 16.67})],  # capped: "faster" named no speed
        [("set_reference_speed", {"v_ref": 20})],  # a speed named now wins, and the reply says so
        [("run_left_lane", {"v_ref": 0})],  # a side named now wins
    ]
    assert "above the 16.667 m/s you told me you prefer; doing as you say now" in _replies(transcript)


def test_a_model_reads_the_memory_as_a_few_lines_of_context(tmp_path):
    path = tmp_path / "alice.yaml"
    _run(["I always prefer passing obstacles on the left.", "Keep the obstacles on the left.", "No, the other side."],
         _memory(path))
    with plain_loop(paper_start_config()) as loop, ScriptedLLM([text("Noted.")]) as llm:
        backend = OpenAIBackend(OpenAISettings(base_url=llm.base_url, api_key_env=None))
        config = AgentConfig(mode="realtime", knowledge=False, warm_up=False, memory=_memory(path))
        with Agent(backend, loop.server, config) as agent:
            agent.deliver("Keep the obstacles on the left please.").result(30)
    content = llm.requests[-1]["messages"][-1]["content"]
    assert content.startswith("Current situation")
    assert "What this passenger told us in earlier runs (memory profile 'alice', agent://memory)" in content
    assert '- standing preference: preferred_side = left (they said: "I always prefer passing obstacles on the left.")' \
        in content
    assert ("- an earlier correction: to \"Keep the obstacles on the left.\" the call "
            "set_preferred_steering_direction(direction='right') was wrong; they wanted "
            "set_preferred_steering_direction(direction='left')") in content
    assert content.endswith("Passenger: Keep the obstacles on the left please.")


def test_the_users_own_edits_are_kept_and_the_file_is_replaced_whole(tmp_path):
    path = tmp_path / "alice.yaml"
    store = MemoryStore(_memory(path), run="r1")
    store.add("preference", "I always prefer passing on the left.", means={"preferred_side": "left"})
    edited = yaml.safe_load(path.read_text())  # the user edits the file during the run: a new entry, a note
    edited["entries"][0]["note"] = "mine"
    edited["entries"].append({"id": 2, "kind": "preference", "said": "(typed by hand)",
                              "means": {"max_speed_mps": 20}})
    path.write_text(yaml.safe_dump(edited))
    store.add("preference", "From now on evade on the right.", means={"preferred_side": "right"})
    entries = read_memory_file(path, "alice")
    assert [(e.id, e.said, e.note) for e in entries] == [
        (1, "I always prefer passing on the left.", "mine"), (2, "(typed by hand)", None),
        (3, "From now on evade on the right.", None)]  # its id moved past the user's
    assert {k: v for k, (v, _) in store.preferences().items()} == {"preferred_side": "right", "max_speed_mps": 20}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["alice.yaml", "alice.yaml.lock"]  # no temporary left


def test_retrieval_is_tfidf_cosine_over_words():
    scores = tfidf_similarities("keep the debris on the left please",
                                ["Keep the debris on the left side.", "An ambulance is coming", "debris"])
    assert scores[0] > 0.7 > scores[2] > scores[1] == 0.0


@pytest.mark.parametrize("content, says", [
    ("version: 1\nprofile: alice\nentries: [\n  - id: 1", "not valid YAML at line"),
    ("version: 2\nprofile: alice\nentries: []\n", "version 2 is not one this agentic-mpc reads (version 1)"),
    ("profile: alice\nentries: []\n", "no 'version'"),
    ("version: 1\nprofile: bob\nentries: []\n", "it is profile 'bob''s, not 'alice''s"),
    ("version: 1\nprofile: alice\nentries:\n- {id: 1, kind: preference, said: hi, means: {preferred_side: left}}\n"
     + "- {id: 5, kind: preference, said: up, means: {preferred_side: up}}\n",
     "entry 2 (id 5): means.preferred_side: Input should be 'left' or 'right'"),
    ("version: 1\nprofile: alice\nentries:\n- {id: 1, kind: correction, said: 'no', corrects: x}\n",
     "entry 1 (id 1): a correction needs 'corrects'"),
])
def test_a_bad_file_is_an_error_naming_the_file_and_the_entry(tmp_path, content, says):
    path = tmp_path / "alice.yaml"
    path.write_text(content)
    with pytest.raises(MemoryFileError) as raised:
        MemoryStore(_memory(path))
    assert str(raised.value).startswith(f"memory file {path}") and says in str(raised.value)


def test_a_bad_file_stops_the_run_unless_the_user_says_to_go_on_without_memory(tmp_path, caplog):
    path = tmp_path / "alice.yaml"
    path.write_text("version: 2\nprofile: alice\nentries: []\n")
    with pytest.raises(MemoryFileError, match=f"memory file {path}: version 2"):
        _run(["Keep the obstacles on the left."], _memory(path))
    with caplog.at_level(logging.WARNING, logger="agentic_mpc.agent.memory"):
        reports, shown, transcript = _run(["I always prefer passing obstacles on the left."],
                                          _memory(path, on_error="ignore"))
    assert _calls(reports[0]) == [("set_preferred_steering_direction", {"direction": "left"})]  # the run went on
    assert any("going on without memory (on_error: ignore)" in r.message for r in caplog.records)
    assert shown["profile"] is None and "version 2" in shown["error"]
    assert any(r.get("event") == "memory_error" for r in transcript)
    assert path.read_text() == "version: 2\nprofile: alice\nentries: []\n"  # never overwritten


def test_settings_default_to_no_memory_and_the_command_line_sets_it():
    from agentic_mpc.agent.settings import agent_settings
    from agentic_mpc.commands import with_agent_settings
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.shipped import scenarios_dir

    assert agent_settings({}).memory is None
    scenario = load_scenario(scenarios_dir() / "paper_steering_preference_plain.yaml").variant(None)
    assert scenario.agent.memory is None
    chosen = with_agent_settings(scenario, [("memory.profile", "bob"), ("memory.on_error", "ignore")]).agent.memory
    assert (chosen.profile, chosen.on_error, chosen.file) == ("bob", "ignore", None)
    assert chosen.path().name == "bob.yaml"
    with pytest.raises(ValueError, match="memory"):
        with_agent_settings(scenario, [("memory.profile", "no spaces")])


def test_on_the_dialogue_set_memory_turns_wrong_answers_right():
    from agentic_mpc.agent_eval.memory_eval import evaluate, summary

    totals = summary(evaluate())
    assert totals["run2_with_memory"] == (15, 15)
    assert totals["run2_without_memory"] == (3, 15)  # the three controls, where memory must change nothing
    assert totals["run1_with_memory"] == (5, 5) and totals["run1_without_memory"] == (0, 5)
