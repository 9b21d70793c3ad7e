"""The knowledge base: documents with their sources, FTS5/BM25 search, the read-only MCP server over stdio."""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

import pytest
from mcp import Client, StdioServerParameters

from agentic_mpc.knowledge.store import KnowledgeBase, KnowledgeError

QUERIES = [  # (question, the document that answers it); measured in docs/knowledge.md
    ("What is the speed limit on a Japanese expressway?", "jp-traffic-rules"),
    ("How long is this car?", "nissan-patrol-manual"),
    ("How do we make way for an ambulance in Germany? Rettungsgasse", "de-traffic-rules"),
    ("An ambulance with a siren in California: where do we stop?", "us-ca-traffic-rules"),
    ("UK motorway speed limit", "uk-traffic-rules"),
    ("two-second rule following distance on British roads", "uk-traffic-rules"),
    ("Autobahn advisory speed", "de-traffic-rules"),
    ("How fast can the Patrol brake to a stop?", "nissan-patrol-manual"),
]


@pytest.fixture(scope="module")
def base():
    return KnowledgeBase()


def test_every_shipped_document_names_its_sources(base):
    assert {"jp-traffic-rules", "de-traffic-rules", "uk-traffic-rules", "us-ca-traffic-rules",
            "nissan-patrol-manual"} <= set(base.documents)
    assert all(document.sources for document in base.documents.values())


@pytest.mark.parametrize(("question", "document"), QUERIES)
def test_the_right_document_ranks_in_the_top_3(base, question, document):
    found = [p.doc_id for p in base.search(question, 3)]
    assert document in found, found


def test_a_users_folder_joins_and_bad_folders_and_documents_are_named(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "trailer.md").write_text("---\ntitle: Our trailer\nsources: [our own measurement]\n---\n"
                                     "## Length\nThe trailer is 7.5 m long.\n")
    base = KnowledgeBase((mine,))
    assert base.search("how long is the trailer", 1)[0].doc_id == "trailer"
    with pytest.raises(KnowledgeError, match="not a directory"):
        KnowledgeBase((tmp_path / "nowhere",))
    (tmp_path / "empty").mkdir()
    with pytest.raises(KnowledgeError, match="no documents"):
        KnowledgeBase((tmp_path / "empty",))
    (mine / "rumour.md").write_text("---\ntitle: A rumour\n---\nSomeone said so.\n")
    with pytest.raises(KnowledgeError, match=r"rumour.md: front matter 'sources' is missing"):
        KnowledgeBase((mine,))


def test_the_server_over_stdio_lists_a_read_only_search_and_the_documents(tmp_path):
    params = StdioServerParameters(command=sys.executable, args=["-m", "agentic_mpc", "knowledge-server"])

    async def go():
        async with Client(params, cache=None) as client:
            tools = (await client.list_tools()).tools
            answer = await client.call_tool("search_knowledge", {"query": "rescue lane", "k": 2})
            refused = await client.call_tool("search_knowledge", {"query": "", "k": 2})
            index = json.loads((await client.read_resource("knowledge://index")).contents[0].text)
            return tools, answer, refused, index

    tools, answer, refused, index = asyncio.run(asyncio.wait_for(go(), 60))
    assert [t.name for t in tools] == ["search_knowledge"] and tools[0].annotations.read_only_hint
    passages = json.loads(answer.content[0].text)["passages"]
    assert passages[0]["document"] == "de-traffic-rules" and "StVO" in passages[0]["cite"]
    assert refused.is_error
    assert {d["id"] for d in index["documents"]} >= {"jp-traffic-rules", "nissan-patrol-manual"}


def test_the_command_refuses_a_missing_folder_with_exit_2(tmp_path, capsys):
    from agentic_mpc.cli import main

    assert main(["knowledge-server", "--folder", str(tmp_path / "nowhere")]) == 2
    assert "nowhere: not a directory" in capsys.readouterr().err


def test_a_search_for_one_jurisdiction_keeps_its_documents_and_the_general_ones(base):
    found = base.search("speed limit motorway car length", 10, "DE")
    assert found and {p.doc_id for p in found} <= {"de-traffic-rules", "nissan-patrol-manual"}
    assert "nissan-patrol-manual" in {p.doc_id for p in base.search("how long is the car", 3, "JP")}


def test_the_knowledge_cases_of_the_suite_find_their_document_in_the_top_3(base):
    """Search quality on the suite's knowledge cases, searched as the rules backend does (the place the
    question names, else the road's; on a motorway with no speed signed, a speed's limit): docs/knowledge.md
    reports it."""
    from agentic_mpc.agent.backends.rules_knowledge import limit_search_call, question_call
    from agentic_mpc.agent_eval.suite import load_suite

    places = {"japan": "JP", "germany": "DE", "california": "US-CA"}
    cases = [c for c in load_suite().select(categories=["knowledge"]) if c.turns[0].cites]
    found = []
    for case in cases:
        place, _, motorway = case.world.partition("_")
        if motorway:
            arguments = limit_search_call(places[place], "motorway")[1]
        else:
            arguments = question_call(case.turns[0].message, places[case.world])[1]
        top = [p.doc_id for p in base.search(arguments["query"], 3, arguments.get("jurisdiction"))]
        found.append(any(doc in top for doc in case.turns[0].cites))
    assert len(cases) == 24 and sum(found) == 24


def test_questions_written_without_the_documents_find_theirs_in_the_top_3(base):
    """benchmarks/knowledge_unseen_questions.yaml: 30 questions written by someone who had not read the
    documents (never tuned on); searched as the rules backend searches. Measured 28 of 30 (docs/knowledge.md)."""
    import yaml

    from agentic_mpc.agent.backends.rules_knowledge import question_call

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "knowledge_unseen_questions.yaml"
    cases = yaml.safe_load(path.read_text(encoding="utf-8"))
    found = 0
    for case in cases:
        arguments = question_call(case["question"])[1]
        found += case["document"] in [p.doc_id for p in base.search(arguments["query"], 3, arguments.get("jurisdiction"))]
    assert len(cases) == 30 and found >= 28
